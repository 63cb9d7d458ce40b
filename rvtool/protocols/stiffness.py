"""Torsional stiffness protocol: fixed input and housing, signed output-torque sequence.

The protocol is data (:class:`TorqueSequence`): signed torque levels through
loading to +T_rated, unloading, reversal to -T_rated and return to zero, with
the ramp and dwell counts and the settling criterion (tail-angle span over the
dwell) that a time-domain path uses. Path (b), :func:`quasi_static_stiffness`,
is an equilibrium continuation: each level is reached from the previous
equilibrium by warm-started Newton solves; the torque increment is halved
when Newton fails or jumps (a step larger than ``max_step`` is rejected: in
the backlash at zero load Newton can land in a far, spurious equilibrium).
Contact history (friction anchors) is committed once per converged level.

Post-processing: branch fits of Eq. (stiffness_fit) over 50-100 % of the
rated torque per branch with R^2, lost motion at +-3 % of rated torque,
zero-load return difference, and the condensed tangent K_t of
Eq. (obs_condensed_stiffness) from the assembled contact Jacobians.
"""
import time
from dataclasses import dataclass

import numpy as np

from .. import progress
from ..errors import RvtoolInputError
from ..validation import check_positive, check_range
from ..solver.continuation import Continuation
from ..units import RAD_PER_ARCMIN

BRANCHES = ("pos_loading", "pos_unloading", "neg_loading", "neg_unloading")


@dataclass(frozen=True, kw_only=True)
class TorqueSequence:
    """Signed output-torque sequence of the stiffness protocol.

    rated_torque: T_rated [N m].
    loading_step: level spacing on the first loading branch [fraction of T_rated].
    other_step: level spacing on unloading, reversal and return [fraction of T_rated].
    fine_levels: extra low-torque levels on every branch [fraction of T_rated]
        (the +-3 % lost-motion levels and 1.5 % on first loading).
    ramp_steps, dwell_steps: time steps of the torque ramp and of the dwell per
        level (time-domain path; the paper commands 600 and 6000).
    reset_interval: kinetic reset (all velocities set to zero) every this many dwell
        steps, and at each level (time-domain path; numerical relaxation, not damping).
    tail_fraction: final fraction of the dwell whose angle span is the settling measure [-].
    settle_span_arcmin: acceptance threshold of the tail-angle span [arcmin].
    """
    rated_torque: float
    loading_step: float = 0.05
    other_step: float = 0.0625
    fine_levels: tuple = (0.015, 0.03)
    ramp_steps: int = 600
    dwell_steps: int = 6000
    reset_interval: int = 250
    tail_fraction: float = 0.25
    settle_span_arcmin: float = 0.5

    def __post_init__(self):
        check_positive("rated_torque", self.rated_torque)
        check_range("loading_step", self.loading_step, 0.0, 1.0, low_open=True)
        check_range("other_step", self.other_step, 0.0, 1.0, low_open=True)
        check_range("tail_fraction", self.tail_fraction, 0.0, 1.0, low_open=True)
        check_positive("settle_span_arcmin", self.settle_span_arcmin)
        for f in self.fine_levels:
            check_range("fine_levels", f, 0.0, 1.0, low_open=True, high_open=True)
        if self.ramp_steps < 1 or self.dwell_steps < 1 or self.reset_interval < 1:
            raise RvtoolInputError(f"ramp_steps = {self.ramp_steps}, dwell_steps = {self.dwell_steps}, "
                                   f"reset_interval = {self.reset_interval}; each must be >= 1")

    def fractions(self):
        """(levels [fraction of T_rated], branch label per level). The peak levels
        (+-1) and the zero at reversal belong to both adjacent branches in the fits."""
        up = sorted(set(np.round(np.arange(0.0, 1.0 + 1e-9, self.loading_step), 10)) | set(self.fine_levels))
        down = sorted(set(np.round(np.arange(0.0, 1.0 + 1e-9, self.other_step), 10)) |
                      {f for f in self.fine_levels if f >= 0.03}, reverse=True)
        levels, labels = [], []
        levels += list(up)
        labels += ["pos_loading"] * len(up)
        levels += down[1:]
        labels += ["pos_unloading"] * (len(down) - 1)
        levels += [-f for f in down[::-1][1:]]
        labels += ["neg_loading"] * (len(down) - 1)
        levels += [-f for f in down[1:]]
        labels += ["neg_unloading"] * (len(down) - 1)
        return np.array(levels, float), labels

    def levels(self):
        """(torques [N m], branch labels)."""
        f, labels = self.fractions()
        return f * self.rated_torque, labels


def rd40_sequence(rated_torque=140.0, **kw):
    """The 74-level sequence: 0..T_rated in 5 % steps plus 1.5 % and 3 %; unloading,
    reversal and return in 6.25 % steps plus 3 %."""
    return TorqueSequence(rated_torque=rated_torque, **kw)


# -- post-processing -------------------------------------------------------------------

def branch_points(torque, labels, rated_torque, lo=0.5, hi=1.0):
    """Indices per branch with lo*T_rated <= |T| <= hi*T_rated. The peak level ending one
    branch also starts the next (the peak of loading is the first point of unloading)."""
    torque = np.asarray(torque, float)
    out = {}
    for b in BRANCHES:
        idx = [i for i, l in enumerate(labels) if l == b]
        if b.endswith("unloading") and idx and idx[0] > 0:
            idx = [idx[0] - 1] + idx
        sel = [i for i in idx if lo * rated_torque - 1e-9 <= abs(torque[i]) <= hi * rated_torque + 1e-9]
        out[b] = sel
    return out


def linear_fit(theta, torque):
    """Eq. (stiffness_fit): least-squares T = K theta + b; returns (K, b, R^2)."""
    x, y = np.asarray(theta, float), np.asarray(torque, float)
    if len(x) < 2:
        raise RvtoolInputError(f"a branch fit needs at least 2 points; got {len(x)}")
    dx = x - x.mean()
    sxx = float(dx @ dx)
    if sxx == 0.0:
        raise RvtoolInputError("a branch fit needs distinct angles; all angles are equal")
    k = float(dx @ (y - y.mean())) / sxx
    b = float(y.mean() - k * x.mean())
    ss_res = float(np.sum((y - (k * x + b)) ** 2))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return k, b, (1.0 - ss_res / ss_tot) if ss_tot > 0 else 1.0


def branch_fits(torque, angle_arcmin, labels, rated_torque, lo=0.5, hi=1.0):
    """Per branch: K [N m/arcmin], intercept [N m], R^2 and the number of points."""
    out = {}
    for b, idx in branch_points(torque, labels, rated_torque, lo, hi).items():
        if len(idx) < 2:
            out[b] = {"K_Nm_per_arcmin": None, "b_Nm": None, "R2": None, "points": len(idx)}
            continue
        k, c, r2 = linear_fit(np.asarray(angle_arcmin)[idx], np.asarray(torque)[idx])
        out[b] = {"K_Nm_per_arcmin": k, "b_Nm": c, "R2": r2, "points": len(idx)}
    return out


def lost_motion_from_levels(torque, angle_arcmin, rated_torque, fraction=0.03):
    """Angle difference [arcmin] between the first +fraction and first -fraction levels
    (the +-3 % definition: the width of the low-stiffness band around zero load)."""
    torque = np.asarray(torque, float)
    t = fraction * rated_torque
    ip = np.flatnonzero(np.isclose(torque, t))
    im = np.flatnonzero(np.isclose(torque, -t))
    if not len(ip) or not len(im):
        raise RvtoolInputError(f"lost motion needs levels at +-{fraction:g} T_rated = +-{t:g} N m; "
                               "the sequence has none")
    return float(angle_arcmin[ip[0]] - angle_arcmin[im[0]])


def zero_load_return(torque, angle_arcmin):
    """Final minus first zero-load angle [arcmin]."""
    iz = np.flatnonzero(np.asarray(torque) == 0.0)
    return float(angle_arcmin[iz[-1]] - angle_arcmin[iz[0]])


def condensed_tangent(model, q):
    """K_t [N m/rad] of Eq. (obs_condensed_stiffness) at state q: K^s assembled from the
    contact Jacobians (K^s = -dQ/dq) and the regularization springs over the free
    coordinates (all but the drive and locks), condensed on the output rotation."""
    K = assembled_stiffness(model, q)
    fixed = model.fixed_coordinates()
    i_out = model.output_index
    r = [i for i in range(len(q)) if i not in fixed and i != i_out]
    k_rr = K[np.ix_(r, r)]
    return float(K[i_out, i_out] - K[i_out, r] @ np.linalg.solve(k_rr, K[r, i_out]))


def assembled_stiffness(model, q):
    """K^s (n, n) [N/m, N m/rad] at state q over all coordinates: minus the contact Jacobians
    plus the elastic structures' own stiffness (a ported housing's eta; none: nothing added) and
    the regularization springs (Eq. obs_condensed_stiffness before condensation)."""
    n = len(q)
    K = np.zeros((n, n))
    for el in model.contact_elements():
        ltg = el.coordinate_indices
        K[np.ix_(ltg, ltg)] -= el.evaluation_at(q).dQdq
    for st in model.structures.values():
        ix = st.coordinate_indices()
        K[np.ix_(ix, ix)] += st.stiffness()
    for i, k in model.regularization_stiffness():
        K[i, i] += k
    return K


def free_stiffness(model, q):
    """(K^s over the free coordinates (all but the drive and the locks), their global indices,
    the position of the output rotation among them)."""
    fixed = model.fixed_coordinates()
    free = [i for i in range(len(q)) if i not in fixed]
    K = assembled_stiffness(model, q)
    return K[np.ix_(free, free)], free, free.index(model.output_index)


# -- path (b): quasi-static continuation ----------------------------------------------

def mesh_contact_stats(model, q):
    """Per member of the model's main mesh (a wheel): (sum of normal forces [N], max normal
    force [N]) over its contacts (slices summed per contact)."""
    members = model.observe(q, model.main_mesh).per_member()
    return [float(np.sum(f)) for f in members.values()], [float(np.max(f)) for f in members.values()]


def quasi_static_stiffness(model, sequence: TorqueSequence, *, input_angle=0.0, record=None, backend="exudyn",
                           device="cpu"):
    """Path (b): run the torque sequence as an equilibrium continuation on the torque path of
    ``backend`` (a name of :data:`rvtool.solver.backends.CHOICES` or a
    :class:`~rvtool.solver.backends.Backend`; task ``"torque_path"``: Exudyn's continuation, the
    device row Newton's). Returns per-level torque [N m], output angle [arcmin] (output rotation
    from its kinematic position), per-wheel pin-force sums and maxima [N], residual diagnostics
    and statistics, ``path`` (the :class:`~rvtool.solver.torque_path.TorquePath`), ``continuation``
    (Exudyn's :class:`Continuation`, None on another backend) and ``backend`` ({"requested",
    "ran", "not_taken"})."""
    from ..solver.backends import choose
    t0 = time.perf_counter()
    torques, labels = sequence.levels()
    b, choice = choose(backend, model, "torque_path", device=device)
    path = b.torque_path(model, input_angle=input_angle)
    angles, sums, maxs, reg = [], [], [], []
    for k, t in enumerate(progress.track(torques, desc="stiffness levels", unit="level")):
        angles.append(path.go_to(float(t)) / RAD_PER_ARCMIN)
        q = path.state()
        s, m = mesh_contact_stats(model, q)
        sums.append(s)
        maxs.append(m)
        reg.append(model.regularization_force(q))
        if record is not None:
            record(k, t, q)
    return {"torque_Nm": torques, "labels": labels, "angle_arcmin": np.array(angles),
            "sum_Fn_N": np.array(sums), "max_Fn_N": np.array(maxs), "regularization_max": max(reg),
            "q_final": path.state(), "continuation": getattr(path, "continuation", None), "path": path,
            "stats": path.stats(), "backend": choice, "wall_s": time.perf_counter() - t0}


def tangent_check(model, torque, *, input_angle=0.0, increment=None, backend="exudyn", device="cpu"):
    """At output torque [N m] (reached by continuation from zero, on the torque path of
    ``backend`` as :func:`quasi_static_stiffness`): the condensed tangent K_t and the
    finite-increment stiffness dT/dtheta from a central torque increment (default 0.1 % of
    |torque|: a 1 % increment at 105 N m of RD-40 already crosses a change of the contact set, a
    slope kink, and differs by 2.3 %). Both in N m/arcmin; their relative difference."""
    from ..solver.backends import choose
    b, choice = choose(backend, model, "torque_path", device=device)
    path = b.torque_path(model, input_angle=input_angle, initial_torque=0.0)
    i_out = model.output_index
    path.go_to(torque)
    q = path.state()
    kt = condensed_tangent(model, q) * RAD_PER_ARCMIN
    dt = increment or 0.001 * abs(torque)
    path.go_to(torque + dt)
    th_p = path.state()[i_out]
    path.go_to(torque)
    path.go_to(torque - dt)
    th_m = path.state()[i_out]
    kfd = 2 * dt / ((th_p - th_m) / RAD_PER_ARCMIN)
    return {"Kt_condensed_Nm_per_arcmin": kt, "K_finite_increment_Nm_per_arcmin": float(kfd),
            "rel_diff": float(abs(kt - kfd) / abs(kfd)), "increment_Nm": dt, "backend": choice}


# -- path (a): dynamic settling with the implicit integrator -----------------------------------

def dynamic_stiffness(model, sequence: TorqueSequence, *, step=2e-5, input_angle=0.0, run_spec=None,
                      max_extra_dwells=2, out_dir=None):
    """Path (a): the torque sequence in time with the generalized-alpha driver. Per level the
    torque ramps linearly over ``ramp_steps`` steps of ``step`` [s], then dwells for
    ``dwell_steps`` steps; velocities are reset to zero (kinetic reset) at each level and every
    ``reset_interval`` dwell steps. A level is accepted when the output-angle span over the
    last ``tail_fraction`` of the dwell is below ``settle_span_arcmin``; otherwise the dwell is
    repeated up to ``max_extra_dwells`` times, after which the level is committed anyway
    (a forced commit, counted). Starts from the static zero-load equilibrium."""
    import dataclasses as dc

    import exudyn as exu

    from ..solver import RunSpec, simulate
    t0 = time.perf_counter()
    torques, labels = sequence.levels()
    mbs = model.mbs
    cont = Continuation(model, input_angle=input_angle)
    q = cont.q.copy()
    i_out = model.output_index
    th_kin = model.kinematic_output(input_angle)
    base = run_spec or RunSpec(end_time=1.0, step=step, abs_tol=1e-6, rel_tol=1e-8)
    elements = model.contact_elements()
    stats = {"steps": 0, "rejected_steps": 0, "kinetic_resets": 0, "forced_commits": 0, "extra_dwells": 0,
             "max_residual": 0.0, "min_step_s": np.inf}
    state = {"q": q}
    trace = []

    def run_chunk(n_steps, load_fn):
        model.set_output_torque_function(load_fn)
        mbs.systemData.SetODE2Coordinates(state["q"], configuration=exu.ConfigurationType.Initial)
        mbs.systemData.SetODE2Coordinates_t(np.zeros_like(state["q"]), configuration=exu.ConfigurationType.Initial)
        stats["kinetic_resets"] += 1
        angles = []

        def rec(t, qq, vv):
            angles.append(qq[i_out])
            state["q"] = np.array(qq)

        r = simulate(mbs, dc.replace(base, end_time=n_steps * step), elements, None, before_accept=rec,
                     out_dir=out_dir)
        stats["steps"] += r.accepted_steps
        stats["rejected_steps"] += r.rejected_steps
        stats["max_residual"] = max(stats["max_residual"], r.max_residual)
        stats["min_step_s"] = min(stats["min_step_s"], r.min_step_s)
        return angles

    t_prev = 0.0
    angles, spans, sums, maxs = [], [], [], []
    t_ramp = sequence.ramp_steps * step
    for k, t_lvl in enumerate(progress.track(torques, desc="dynamic stiffness levels", unit="level")):
        a, b = t_prev, float(t_lvl)
        run_chunk(sequence.ramp_steps, lambda t, a=a, b=b: a + (b - a) * min(t / t_ramp, 1.0))
        for attempt in range(1 + max_extra_dwells):
            dwell = []
            left = sequence.dwell_steps
            while left > 0:
                n = min(left, sequence.reset_interval)
                dwell += run_chunk(n, lambda t, b=b: b)
                left -= n
            n_tail = max(2, int(round(sequence.tail_fraction * len(dwell))))
            span = float(np.ptp(dwell[-n_tail:])) / RAD_PER_ARCMIN
            if span <= sequence.settle_span_arcmin:
                break
            stats["extra_dwells"] += 1
        else:
            stats["forced_commits"] += 1
        trace.append(np.array(dwell))
        spans.append(span)
        angles.append((state["q"][i_out] - th_kin) / RAD_PER_ARCMIN)
        s_, m_ = mesh_contact_stats(model, state["q"])
        sums.append(s_)
        maxs.append(m_)
        t_prev = b
    model.set_output_torque_function(None)
    stats["min_step_s"] = None if not np.isfinite(stats["min_step_s"]) else stats["min_step_s"]
    return {"torque_Nm": torques, "labels": labels, "angle_arcmin": np.array(angles),
            "tail_span_arcmin": np.array(spans), "sum_Fn_N": np.array(sums), "max_Fn_N": np.array(maxs),
            "stats": stats, "wall_s": time.perf_counter() - t0, "step_s": step}
