"""Contact selection and the pressure-resolution study at a fixed mechanical state
(paper Appendix "Local pressure reconstruction and comparison procedure").

Procedure: the contacts of one wheel and family are :class:`~rvtool.pressure.state.LocalContact`
objects frozen at the accepted state. Each is solved once at ONE selection resolution over its own
physical domain; the contact with the largest fixed-window mean pressure of Eq. (pressure_metrics)
is selected. Its identity, force, gap and domain are then kept for every resolution N, so refinement
tests local pressure resolution only (Eqs. pressure_metrics, pressure_field_difference).
"""
import time

import numpy as np

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_positive

from .metrics import field_difference, successive_changes_pct
from .panels import PanelContact, solve_panels


def domain_halfwidth(contact, factor=3.0):
    """Physical half-length of the panel domain [m]: ``factor`` Hertz half-widths, within the gap's extent."""
    check_positive("factor", factor)
    return float(min(factor * contact.hertz_halfwidth, contact.extent))


def solve_contact(contact, n, half, window, initial_active=None):
    """Panel solution of ``contact`` with n uniform panels on [-half, half] [m] and the mean window [m]."""
    x = np.linspace(-half, half, int(n))
    pc = PanelContact(face_width=contact.face_width, e_star=contact.e_star, force=contact.force, mean_window=window)
    return solve_panels(pc, x, contact.gap(x), initial_active=initial_active)


def select_contact(contacts, *, n_select, window, factor=3.0):
    """The contact with the largest fixed-window mean pressure at the selection resolution n_select.

    Returns (selected LocalContact, table {name: p_window [Pa]})."""
    if not contacts:
        raise RvtoolInputError("contacts: no loaded contact to select from (empty list)")
    table = {}
    for c in contacts:
        table[c.name] = solve_contact(c, n_select, domain_halfwidth(c, factor), window).p_window
    best = max(contacts, key=lambda c: table[c.name])
    return best, table


def resolution_study(contact, ns, *, half, window, peak_target_pct=2.0, span_target_pct=1.0):
    """Resolution sequence of one frozen contact; ``ns`` increasing, the last is the reference.

    Returns (record dict, fields [(x, p)]). The record holds N, p_raw [Pa], p_window [Pa], span [m],
    e1 against the finest field in % (Eq. pressure_field_difference), successive changes in % and
    ``converged``: the finest pair changes p_raw by less than peak_target_pct and the span by less than
    span_target_pct. wall_s is the panel solve alone (gap sampling excluded)."""
    ns = [int(n) for n in ns]
    if sorted(ns) != ns or len(set(ns)) != len(ns) or len(ns) < 2:
        raise RvtoolInputError(f"ns = {ns}: need at least two increasing resolutions")
    rec = {"contact": contact.name, "family": contact.family, "force_N": contact.force,
           "face_width_m": contact.face_width, "domain_halfwidth_m": half, "window_m": window,
           "hertz_p0_Pa": contact.hertz_peak, "hertz_halfwidth_m": contact.hertz_halfwidth,
           "slice_force_ratio": contact.slice_force_ratio,
           "N": [], "p_raw": [], "p_window": [], "span": [], "load_residual": [], "iterations": [], "wall_s": []}
    fields = []
    for n in ns:
        x = np.linspace(-half, half, n)
        g = contact.gap(x)
        pc = PanelContact(face_width=contact.face_width, e_star=contact.e_star, force=contact.force,
                          mean_window=window)
        t0 = time.perf_counter()
        r = solve_panels(pc, x, g)
        rec["wall_s"].append(time.perf_counter() - t0)
        for k, v in (("N", n), ("p_raw", r.p_raw), ("p_window", r.p_window), ("span", r.span),
                     ("load_residual", r.load_residual), ("iterations", r.iterations)):
            rec[k].append(v)
        fields.append((x, r.pressure))
    xf, pf = fields[-1]
    rec["e1_vs_4097_pct"] = [100 * field_difference(x, p, xf, pf) for x, p in fields]
    rec["e1_reference_N"] = ns[-1]
    rec["p_raw_change_pct"] = successive_changes_pct(rec["p_raw"])
    rec["span_change_pct"] = successive_changes_pct(rec["span"])
    rec["p_window_change_pct"] = successive_changes_pct(rec["p_window"])
    rec["converged"] = bool(rec["p_raw_change_pct"][-1] < peak_target_pct and rec["span_change_pct"][-1] < span_target_pct)
    rec["targets_pct"] = {"p_raw": peak_target_pct, "span": span_target_pct}
    return rec, fields
