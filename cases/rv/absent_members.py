"""Effects absent from the all-members-on torque path of rv40e / rv80e, each estimated (issues 28 / 30, the rigidity
gap: the model is about 1.7 times stiffer than the catalogue with every member on).

The all-members-on design is ``rvtool validate``'s row (the members files at the middles of their ranges, validate's
quick meshes; :func:`rigidity_gap.all_on_design`). Its tangent stiffness K_t at T_R is taken by a central difference
of the output angle over T_R (1 +- DERIV_STEP), input held (the catalogue's test: "a torque is applied to the output
shaft while the input shaft is fixed", as quoted in ``rv40e_catalogue.toml`` [test]). Each effect below is either
switched on with the machinery that exists and measured as the change of that K_t, or estimated from a closed form
evaluated on the model's own state at T_R. Nothing is fitted and no input moves: every input stays at its committed
middle.

Measured (an existing switch the all-on row leaves off):

* ``bore_patches``: the eccentric needle set's outer raceway is the wheel's crank bore. The all-on row carries the
  bore as its mean motion (``wheels.structure.bore_ports = 0``, the default; ``docs/guide/wheel_body.md``: stiffer
  than a journal pressing on the loaded arc). With ``bore_ports = N`` the journal presses on N compression-only
  patches and the bore ovalises (:mod:`rvtool.contact.bore_patches`). N = BORE_PORTS (quick: BORE_PORTS_QUICK).
* ``crank_pair_tilt`` (rv40e only; rv80e has it on): the crank tilting on its tapered pair
  (``cranks.shaft.tilt = true``, :func:`rvtool.assembly.rv.builder.crank_station_compliance`).

Estimated from a closed form on the model's state:

* ``needle_misalignment``: the crank's bending slope (and, with ``tilt``, its tilt on the pair) across each needle
  journal. The planar model's needle law sees the journal's mean deflection only (the station is the mean over the
  needle length). Here every roller's load Q_i (the model's, at T_R +- h) is carried by Palmgren's law in slices along
  the roller (the lamina form of Harris & Kotzalas 2007: q(x) = (delta(x) / c)^(10/9) / l per unit length, c from
  delta = 2 x 3.84e-5 Q^0.9 / l^0.8 [mm, N] over both raceways) with the approach delta(x) = delta_0 + gamma_i x,
  gamma_i = s . n_i the journal's slope s (by virtual work on the simply supported Timoshenko beam,
  :func:`rigidity_gap.beam_flexibility`, the journal loads spread over the needle length; the spur gear's force left
  out as in ``rigidity_gap``) projected on the roller's normal. delta_0 solves Q(delta_0, gamma_i) = Q_i; the change
  of the member's compliance is sum_i (dQ_i/dT)(d e_i/dT), e_i = delta_0 - delta_flat(Q_i) (first order: the
  forces' pattern unchanged). Convexity of q(delta) makes e_i <= 0 (the mid-plane approach that carries Q_i never
  exceeds the aligned one); the tangent change along the torque path may take either sign and is what is reported.
  (The moment the tilted contact puts on the journal is a further restraint on the crank's bending, a stiffness in
  parallel, which cannot add compliance.)

From the full run's budget (``stiffness_budget`` of the all-on state; --quick leaves it out):

* ``input_vs_cranks_held``: holding the cranks instead of the input removes the involute stage and crank torsion from
  the torque path; their energy share is that compliance to first order (``compliance_budget`` checks energy against
  switch-on shares).
* ``effective_length``: every roller and pin contact follows Palmgren's l^-0.8 (the rv40e pins' ``line`` law is its
  secant at a reference force, also ~ l^-0.8); a fraction eps shorter effective length (edge chamfers, crowning)
  raises those members' compliance by (1 - eps)^-0.8 - 1. Reported per EFFECTIVE_LENGTH_EPS, a sensitivity: the
  rollers' effective lengths are not in any read source.

Measured on the class design without the FE members:

* ``friction_sign``: the validation designs are frictionless. Whether friction at the loaded contacts lowers a
  loading branch's b/a is measured on rv40e as ``cases/cycloid/hysteresis_friction.py`` runs it (anchor friction
  MU_FRICTION on the pin mesh and the involute stage, path (b), the catalogue sequence at 12.5 % steps; anchors are
  refused beside the ported wheels, so the design is rv40e as shipped, its FE members off): the four branch fits
  over 50-100 % T_R at MU_FRICTION against the same protocol at mu = 0.

Manufacturing errors (the rigidity row is nominal):

* ``tolerance_variants`` (rv80e only: its tolerance grades are cited per line in ``rv80e_tolerances.toml``, ISO
  1328-1:2013 and ISO 286-1; rv40e's are chosen): b/a on the catalogue's stated points
  (:func:`rvtool.analysis.validate_members.rigidity_ba`) of the tolerance variants
  (:func:`rvtool.variants.rv_tolerances.sample_rv_design`, seed :data:`rvtool.analysis.validate_te.SEED`, the TE
  row's variants) against the nominal design: rv80e as shipped (its housing ports and elastic tilting cranks; every
  field) and, in the full run, the all-members-on row without the wheel- and carrier-bore position fields (refused
  beside the ported wheels and carrier: their FE bores sit at their true positions).

A break-even and a cited estimate:

* ``carrier_joint``: the real carrier's end plate is bolted and pinned to the pillars; the model's carrier is one
  body. A joint in series at every pillar carries the end plate's half of the crank seats' load, as the pillar bound
  of ``rigidity_gap``: C_joint = (1/2)^2 / (n_p k_j R_p^2). Reported: the joint stiffness k_j* at which it adds
  JOINT_SHARE of the all-on compliance, as a multiple of the pillar's own fixed-guided stiffness k_p and as a
  tangential stiffness per unit area of the pillar's face (k_j* / (pi r_p^2)); and the joint's share with the
  measured unit tangential contact stiffness of steel interfaces (UNIT_NORMAL_CONTACT_STIFFNESS x
  TANGENTIAL_TO_NORMAL, Kono et al. 2012) over the pillar's face, the joint not slipping. Whether it slips depends on
  the bolts' clamp, which no read source gives; the shear each pillar's joint carries at T_R is reported.

--quick: rv40e only (no budget), bore patches at BORE_PORTS_QUICK, the friction sign, 2 shipped tolerance variants
(under a minute); full: rv40e and rv80e, BORE_PORTS, the budget's items, 32 shipped and 16 all-members-on tolerance
variants, and the absent effects summed beside the compliance the catalogue's rigidity would need (``absent_sum``;
about 7 minutes on the loaded 2-core box).

Checks: the slice law reproduces the unsliced Palmgren law at gamma = 0 (SLICE_TOL) and its closed form matches
quadrature in partial contact (QUAD_TOL); the central-difference K_t matches the budget's tangent in the full run
(KT_TOL); every figure finite; the needle estimate's sign (e_i <= 0 for every roller, the convexity argument); the
friction sign the page reads (both loading branches' fits with friction at least the frictionless ones).
"""
import copy
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.optimize import brentq

import rvtool
from rvtool import casekit, designs
from rvtool.analysis.validate_members import QUICK_NUMERICS, load_members, members_name, members_table
from rvtool.assembly.rv.builder import crank_pair_tilt_stiffness, rated_crank_bearing_load
from rvtool.assembly.topologies import design_from_table, read_table
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver
from rvtool.units import RAD_PER_ARCMIN

rg = casekit.import_case("rv/rigidity_gap")

DESIGNS_QUICK = ("rv40e",)
DESIGNS_FULL = ("rv40e", "rv80e")
DERIV_STEP = 0.01
"""K_t and dQ/dT by central differences over T_R (1 +- 0.01), as ``rigidity_gap``."""
BORE_PORTS = 16
"""Bore patches per crank bore in the full run: 8 and 16 differ by a fraction of a per cent on one wheel
(``wheel_body_contact``, ratio_by_bore_ports)."""
BORE_PORTS_QUICK = 8
PALMGREN_P = 10.0 / 9.0
"""Load exponent of Palmgren's line contact in load-from-approach form, q ~ delta^(10/9)."""
EFFECTIVE_LENGTH_EPS = 0.1
"""A 10 % shorter effective contact length: the sensitivity's step (no read source gives the rollers' chamfers)."""
JOINT_SHARE = 0.05
"""Issue 30's skip threshold: a member under 5 % of the compliance may be skipped."""
UNIT_NORMAL_CONTACT_STIFFNESS = (1e6 * 1e9, 2e6 * 1e9)
"""N/m^3: measured unit normal contact stiffness of steel and cast-iron interfaces, "1-2 x 10^6 N/mm/mm^2" (Kono,
Inagaki, Matsubara, Yamaji, Measurement of Contact Stiffness for Stiffness Estimation of Machine Tool Supports, Key
Engineering Materials 523-524 (2012) 457-462, abstract as stored at scientific.net). The laboratory's own abstract
page (mmc.me.kyoto-u.ac.jp) prints the figure with its exponent's superscript lost ("1-2107", 10^7 if so read): the
lower reading is taken, the softer joint. Measured on machine-tool supports, not on a bolted carrier; the pressure
is not in the abstract (contact stiffness rises with pressure; a bolt's clamp is a high one)."""
TANGENTIAL_TO_NORMAL = (0.1, 0.2)
"""The unit tangential contact stiffness is "1/10-1/5 of the unit normal contact stiffness" (Kono et al. 2012, as
above)."""
SLICE_TOL = 1e-12
"""The slice law at gamma = 0 against the unsliced law: both closed forms, round-off only."""
QUAD_TOL = 1e-8
"""The slice law's closed form against adaptive quadrature in partial contact (quadrature's own tolerance 1e-12)."""
KT_TOL = 2e-3
"""Central-difference K_t (truncation O(h^2) ~ 1e-4 of a smooth power law) against the budget's condensed tangent."""
TOLERANCE_VARIANTS = {"shipped": (2, 32), "all_on": (0, 16)}
"""Variants (quick, full) per configuration of ``tolerance_variants``: one shipped variant costs ~1 s, one
all-members-on variant 8-15 s (measured on the loaded 2-core box)."""
REFUSED_WITH_PORTED = ("wheel_bore_position_error", "carrier_bore_position_error")
"""Tolerance fields the ported wheels and carrier refuse (their FE bores sit at their true positions)."""
MU_FRICTION = 0.05
"""Anchor friction of ``hysteresis_friction`` (its MU): the sign test's coefficient."""
PATHS_OF_LENGTH = ("pins", "eccentric_bearings", "crank_bearings")
"""Budget paths whose law scales as Palmgren's l^-0.8 (pins: Palmgren or its ``line`` secant)."""


def _merge(a, b):
    out = copy.deepcopy(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def all_on(name, extra=None):
    """The all-members-on design of ``rvtool validate`` (as :func:`rigidity_gap.all_on_design`) with ``extra``
    design-file tables merged last."""
    switches, derived, assumed, _ = load_members(members_name(name))
    mid = {a.key: a.middle for a in assumed.inputs}
    numerics = _merge(QUICK_NUMERICS, extra or {})
    return design_from_table(members_table(read_table(designs.path(name)), switches, derived, mid, numerics))


class Static:
    """The model of ``design`` solved at T_R (1 + f) for f in (-h, 0, h), input held."""

    def __init__(self, design, observe=()):
        self.design = d = design
        self.model = m = rvtool.build(d)
        self.sign = -np.sign(m.ratio)
        self.T = d.rated_torque
        self.theta, self.obs, self.q = {}, {}, {}
        fam = {f.value: f for f in m.families}
        for f in (-DERIV_STEP, DERIV_STEP, 0.0):          # T_R last: the state the budget reads
            m.set_output_torque(self.sign * (1 + f) * self.T)
            q = StaticSolver(m).solve(0.0)
            self.q[f], self.theta[f] = q, float(q[m.output_index])
            self.obs[f] = {k: m.observe(q, fam[k]) for k in observe}
        self.C = abs(self.theta[DERIV_STEP] - self.theta[-DERIV_STEP]) / (2 * DERIV_STEP * self.T)   # rad/(N m)
        self.K_t = RAD_PER_ARCMIN / self.C                                                          # N m/arcmin


# --- the needle slices ---------------------------------------------------------------------------------------------
def palmgren_c(l):
    """c [m N^-0.9] of delta = c Q^0.9 over both raceways of a roller of length l [m] (Palmgren)."""
    return 2 * rg.PALMGREN * 1e-3 / (l * 1e3) ** 0.8


def slice_load(d0, gamma, l, c):
    """Q [N] of a roller of length l whose approach is d0 + gamma x along it, x in [-l/2, l/2], Palmgren in slices:
    Q = (1/l) int (max(0, d0 + gamma x) / c)^(10/9) dx, i.e. q = (delta / c)^(10/9) / l per unit length (uniform
    approach: Q = (delta / c)^(10/9), the unsliced law), integrated in closed form."""
    p = PALMGREN_P
    g = abs(gamma)
    if g == 0.0:
        return (d0 / c) ** p if d0 > 0 else 0.0
    b = d0 + g * l / 2
    a = max(d0 - g * l / 2, 0.0)
    if b <= 0:
        return 0.0
    return (b ** (p + 1) - a ** (p + 1)) / ((p + 1) * g * l * c ** p)


def slice_quadrature(d0, gamma, l, c):
    from scipy.integrate import quad
    kink = -d0 / gamma if gamma else None
    pts = [kink] if kink is not None and -l / 2 < kink < l / 2 else None
    val = quad(lambda x: max(d0 + gamma * x, 0.0) ** PALMGREN_P, -l / 2, l / 2, epsabs=0.0, epsrel=1e-13, limit=200,
               points=pts)[0]
    return val / (l * c ** PALMGREN_P)


def tilted_approach(Q, gamma, l, c):
    """delta_0 [m] at the roller's mid-plane that carries Q under the misalignment gamma."""
    flat = c * Q ** 0.9
    if Q <= 0:
        return 0.0
    g = abs(gamma)
    if g == 0.0:
        return flat
    return brentq(lambda d0: slice_load(d0, gamma, l, c) - Q, -g * l / 2, flat + g * l, xtol=1e-18, rtol=1e-14)


def journal_slope_influence(design):
    """S (n_w, n_w) [rad/N]: the mean slope over journal j (end deflections' difference over the needle length)
    under a unit resultant spread over journal j', by virtual work on the simply supported Timoshenko beam."""
    sh = design.cranks.shaft
    l = design.eccentric_bearing.roller_length
    mid = 0.5 * sum(sh.supports)
    sup = tuple(x - mid for x in sh.supports)
    zj = [z - mid for z in design.wheels.midplanes]
    n = rg.BEAM_POINTS
    pts = [float(x) for z in zj for x in np.linspace(z - l / 2, z + l / 2, n)]
    ends = [e for z in zj for e in (z - l / 2, z + l / 2)]
    B = rg.beam_flexibility(pts + ends, sup, sh.radius, design.material.youngs_modulus, design.material.poisson_ratio)
    nl = len(pts)
    S = np.zeros((len(zj), len(zj)))
    for j in range(len(zj)):
        for jp in range(len(zj)):
            cols = slice(jp * n, (jp + 1) * n)
            S[j, jp] = (B[nl + 2 * j + 1, cols].mean() - B[nl + 2 * j, cols].mean()) / l
    return S, np.array(zj)


def rollers(o, idx):
    """{roller id: (Q [N], normal (2,))} of one bearing's rows (its laminae summed)."""
    out = {}
    nrm = np.asarray(o.normal)[:, :2]
    for i in idx:
        r = o.ids[i].rsplit("/", 1)[0]
        Q, n = out.get(r, (0.0, nrm[i]))
        out[r] = (Q + float(o.normal_force[i]), n)
    return out


def needle_misalignment(st):
    d = st.design
    sh = d.cranks.shaft
    l = d.eccentric_bearing.roller_length
    c = palmgren_c(l)
    S, zj = journal_slope_influence(d)
    K_gamma = crank_pair_tilt_stiffness(d, rated_crank_bearing_load(d)) if sh.tilt else None
    e, Qs, slopes, worst = {}, {}, [], []
    for f in (-DERIV_STEP, DERIV_STEP, 0.0):
        o = st.obs[f]["eccentric_bearings"]
        grp = rg.group(o.ids, r"eccentric_bearing_c(\d+w\d+)/")
        vec = o.normal_force[:, None] * np.asarray(o.normal)[:, :2]
        for k in range(d.cranks.count):
            P = np.array([vec[grp[f"{k}w{j}"]].sum(axis=0) for j in range(len(zj))])
            s = S @ P
            if K_gamma is not None:
                # the crank tilting on its pair about the pair's centre under the journals' moment (the beam's
                # supports' frame); the same tilt at every journal
                s = s + (zj @ P) / K_gamma
            for j in range(len(zj)):
                for r, (Q, n) in rollers(o, grp[f"{k}w{j}"]).items():
                    g = float(s[j] @ n)
                    d0 = tilted_approach(Q, g, l, c)
                    e[(f, r)] = d0 - c * Q ** 0.9 if Q > 0 else 0.0
                    Qs[(f, r)] = Q
                    if f == 0.0 and Q > 0:
                        worst.append((Q, abs(g) * l / 2, c * Q ** 0.9))
                if f == 0.0:
                    slopes.append(float(np.hypot(*s[j])))
    names = sorted({r for (_, r) in e})
    h, up, dn = DERIV_STEP * st.T, DERIV_STEP, -DERIV_STEP
    dC = sum((Qs[(up, r)] - Qs[(dn, r)]) / (2 * h) * (e[(up, r)] - e[(dn, r)]) / (2 * h) for r in names)
    Qm, edge, flat = max(worst)
    return {"added_compliance_arcmin_per_Nm": dC / RAD_PER_ARCMIN, "share_of_all_on": dC / st.C,
            "max_e_at_T_R_m": max(e[(0.0, r)] for r in names),
            "journal_slope_max_rad": max(slopes), "journal_slope_min_rad": min(slopes),
            "most_loaded_roller": {"Q_N": Qm, "edge_offset_m": edge, "flat_approach_m": flat,
                                   "edge_over_approach": edge / flat},
            "pair_tilt_included": bool(sh.tilt),
            "pair_tilt_stiffness_Nm_per_rad": K_gamma}


def carrier_joint(st):
    d = st.design
    cs = d.carrier.structure
    n_p, R_p, r_p = d.cranks.count, cs.pillar_circle_radius, cs.pillar_radius
    k_p = rg.pillar_stiffness(d)
    k_star = 0.25 / (n_p * R_p ** 2 * JOINT_SHARE * st.C)
    area = math.pi * r_p ** 2
    cited = sorted(kn * rt for kn in UNIT_NORMAL_CONTACT_STIFFNESS for rt in TANGENTIAL_TO_NORMAL)
    share = [0.25 / (n_p * (kt * area) * R_p ** 2) / st.C for kt in (cited[0], cited[-1])]
    return {"k_joint_break_even_N_per_m": k_star, "over_pillar_stiffness": k_star / k_p,
            "per_area_break_even_N_per_m3": k_star / area, "pillar_k_N_per_m": k_p,
            "pillar_shape": cs.pillar_shape, "share": JOINT_SHARE,
            "cited_tangential_per_area_N_per_m3": [cited[0], cited[-1]],
            "share_at_cited_softest": share[0], "share_at_cited_stiffest": share[1],
            "cited_over_break_even": cited[0] / (k_star / area),
            "shear_per_pillar_at_T_R_N": 0.5 * st.T / (n_p * R_p),
            "formula": "C_joint = (1/2)^2 / (n_p k_j R_p^2) (the end plate's half of the seat loads through the pillars), "
                       "k_j = k_t'' pi r_p^2 over the pillar's face, no slip"}


def study(name, quick):
    t0 = time.perf_counter()
    base = Static(all_on(name), observe=("eccentric_bearings",))
    out = {"K_t_all_on_Nm_per_arcmin": base.K_t, "C_all_on_arcmin_per_Nm": base.C / RAD_PER_ARCMIN}
    nb = BORE_PORTS_QUICK if quick else BORE_PORTS
    bore = Static(all_on(name, {"wheels": {"structure": {"bore_ports": nb}}}))
    out["bore_patches"] = {"bore_ports": nb, "K_t_Nm_per_arcmin": bore.K_t,
                           "share_of_all_on": (bore.C - base.C) / base.C}
    if not base.design.cranks.shaft.tilt:
        tilt = Static(all_on(name, {"cranks": {"shaft": {"tilt": True}}}))
        out["crank_pair_tilt"] = {"K_t_Nm_per_arcmin": tilt.K_t, "share_of_all_on": (tilt.C - base.C) / base.C}
    else:
        out["crank_pair_tilt"] = {"note": "on in the all-members-on row already (cranks.shaft.tilt = true)"}
    out["needle_misalignment"] = needle_misalignment(base)
    out["carrier_joint"] = carrier_joint(base)
    if not quick:
        b = stiffness_budget(base.model, base.q[0.0])
        sh = b["shares"]
        out["budget_K_t_Nm_per_arcmin"] = float(b["K_t_Nm_per_arcmin"])
        out["K_t_rel_diff"] = abs(out["budget_K_t_Nm_per_arcmin"] - base.K_t) / base.K_t
        out["energy_shares"] = {k: float(v) for k, v in sh.items()}
        out["input_vs_cranks_held"] = {
            "share_of_all_on": float(sh.get("involute_stage", 0.0) + sh.get("crank_torsion", 0.0)),
            "involute_stage": float(sh.get("involute_stage", 0.0)), "crank_torsion": float(sh.get("crank_torsion", 0.0))}
        lsum = float(sum(sh.get(p, 0.0) for p in PATHS_OF_LENGTH))
        out["effective_length"] = {"eps": EFFECTIVE_LENGTH_EPS, "shares_scaling_as_l^-0.8": lsum,
                                   "share_of_all_on": lsum * ((1 - EFFECTIVE_LENGTH_EPS) ** -0.8 - 1)}
    out["wall_s"] = time.perf_counter() - t0
    return out


def friction_sign():
    """Branch fits of rv40e's catalogue loop with anchor friction MU_FRICTION and without (module docstring)."""
    hf = casekit.import_case("cycloid/hysteresis_friction")
    t0 = time.perf_counter()
    fits = {mu: hf.rv_quasi_static(mu, True)["figures"].branch_fits for mu in (0.0, MU_FRICTION)}
    K = {mu: {b: float(f["K_Nm_per_arcmin"]) for b, f in fits[mu].items()} for mu in fits}
    return {"mu": MU_FRICTION, "K_fit_frictionless_Nm_per_arcmin": K[0.0],
            "K_fit_friction_Nm_per_arcmin": K[MU_FRICTION],
            "ratio_to_frictionless": {b: K[MU_FRICTION][b] / K[0.0][b] for b in K[0.0]},
            "fit_range": "50-100 % T_R, least squares per branch (hysteresis_friction's branch_fits)",
            "wall_s": time.perf_counter() - t0}


def tolerance_variants(quick):
    """b/a of rv80e's tolerance variants against the nominal design (module docstring)."""
    import dataclasses

    from rvtool.analysis.validate_members import rigidity_ba
    from rvtool.analysis.validate_te import SEED
    from rvtool.designs.catalogue import load_catalogue
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    name = "rv80e"
    cat = load_catalogue(designs.catalogue_of(name))
    spec = load_rv_tolerances(designs.path(f"{name}_tolerances"))
    out = {"design": name, "seed": SEED, "points": "the catalogue's stated b/a points (validate)"}
    for config, (n_quick, n_full) in TOLERANCE_VARIANTS.items():
        n = n_quick if quick else n_full
        if n == 0:
            continue
        t0 = time.perf_counter()
        if config == "shipped":
            d, sp, left = rvtool.load_design(designs.path(name)), spec, []
        else:
            d = all_on(name)
            sp = dataclasses.replace(spec, **{f: None for f in REFUSED_WITH_PORTED})
            left = list(REFUSED_WITH_PORTED)
        nominal = rigidity_ba(d, cat)["value"]
        ratios, failed = [], []
        for k in range(n):
            try:
                dv, _ = sample_rv_design(sp, d, k, SEED)
                ratios.append(rigidity_ba(dv, cat)["value"] / nominal)
            except Exception as exc:            # counted and reported, as a band sample
                failed.append(f"variant {k}: {type(exc).__name__}: {exc}"[:300])
        r = np.array(ratios)
        out[config] = {"nominal_ba_Nm_per_arcmin": nominal, "variants": n, "failed": failed,
                       "ratio_to_nominal": r.tolist(), "mean_ratio": float(r.mean()), "min_ratio": float(r.min()),
                       "max_ratio": float(r.max()), "std_ratio": float(r.std(ddof=1)) if len(r) > 1 else 0.0,
                       "fraction_below_nominal": float(np.mean(r < 1.0)), "fields_left_out": left,
                       "wall_s": time.perf_counter() - t0}
    return out


def absent_sum(name, a, tol):
    """The measured and estimated absent effects of ``name`` summed as series compliances (first order) beside the
    compliance the catalogue's rigidity would need: b/a (validate's all-on row) / catalogue - 1. The catalogue figure
    carries its reading status."""
    from rvtool.analysis.validate_members import rigidity_ba
    from rvtool.designs.catalogue import load_catalogue
    cat = load_catalogue(designs.catalogue_of(name))
    fig = cat.figure("torsional_rigidity")
    ba = rigidity_ba(all_on(name), cat)["value"]
    parts = {"bore_patches": a["bore_patches"]["share_of_all_on"],
             "needle_misalignment": a["needle_misalignment"]["share_of_all_on"],
             "carrier_joint_no_slip_cited_softest": a["carrier_joint"]["share_at_cited_softest"]}
    if "share_of_all_on" in a["crank_pair_tilt"]:
        parts["crank_pair_tilt"] = a["crank_pair_tilt"]["share_of_all_on"]
    if name == tol.get("design") and "all_on" in tol:
        parts["manufacturing_errors_mean"] = 1.0 / tol["all_on"]["mean_ratio"] - 1.0
    return {"parts": parts, "sum": float(sum(parts.values())), "ba_all_on_Nm_per_arcmin": ba,
            "catalogue_Nm_per_arcmin": fig.value, "catalogue_status": fig.status,
            "compliance_needed_for_catalogue": ba / fig.value - 1.0,
            "left_out": "effective contact length (a sensitivity, no source), a slipping carrier joint and the cups' "
                        "fit (no source), the test fixture"}


def slice_checks():
    l, Q, c = 0.010, 800.0, palmgren_c(0.010)
    flat = c * Q ** 0.9
    at0 = abs(slice_load(flat, 0.0, l, c) - Q) / Q
    g = 4 * flat / l                                       # partial contact: the edge offset is twice the approach
    d0 = 0.3 * flat
    quad_err = abs(slice_load(d0, g, l, c) - slice_quadrature(d0, g, l, c)) / slice_quadrature(d0, g, l, c)
    full_err = abs(slice_load(flat, 0.1 * flat / l, l, c) - slice_quadrature(flat, 0.1 * flat / l, l, c)) / Q
    return at0, max(quad_err, full_err)


def judge(r):
    c = {"slice_law_at_zero_tilt": casekit.check(r["slice_checks"]["at_zero_tilt_rel_err"], SLICE_TOL, "<=",
                                                  "the sliced law with a uniform approach is the unsliced Palmgren law"),
         "slice_law_quadrature": casekit.check(r["slice_checks"]["quadrature_rel_err"], QUAD_TOL, "<=",
                                               "closed form of the slice integral vs adaptive quadrature")}
    for config, t in r["tolerance_variants"].items():
        if isinstance(t, dict):
            c[f"tolerances_{config}_failed"] = casekit.check(len(t["failed"]), 0, "==",
                                                             "every tolerance variant solves (none counted out)")
    fs = r["friction_sign"]["ratio_to_frictionless"]
    c["friction_does_not_lower_loading"] = casekit.check(
        min(fs["pos_loading"], fs["neg_loading"]), 1.0, ">=",
        "the page's reading: anchor friction at the loaded contacts does not lower the loading branches' fit")
    for name, a in r["designs"].items():
        c[f"{name}_needle_sign"] = casekit.check(a["needle_misalignment"]["max_e_at_T_R_m"], 0.0, "<=",
                                                 "convexity: the mid-plane approach that carries a roller's load under "
                                                 "misalignment never exceeds the aligned one")
        if "K_t_rel_diff" in a:
            c[f"{name}_K_t_central_vs_budget"] = casekit.check(a["K_t_rel_diff"], KT_TOL, "<=",
                                                               "central difference vs the budget's condensed tangent")
    return c


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    at0, qerr = slice_checks()
    names = DESIGNS_QUICK if args.quick else DESIGNS_FULL
    results = {"slice_checks": {"at_zero_tilt_rel_err": at0, "quadrature_rel_err": qerr},
               "designs": {n: study(n, args.quick) for n in names}}
    results["friction_sign"] = friction_sign()
    results["tolerance_variants"] = tolerance_variants(args.quick)
    if not args.quick:
        for n in names:
            results["designs"][n]["absent_sum"] = absent_sum(n, results["designs"][n], results["tolerance_variants"])
    casekit.verdict(results, judge)
    settings = {"quick": args.quick, "deriv_step": DERIV_STEP, "bore_ports": BORE_PORTS_QUICK if args.quick else BORE_PORTS,
                "effective_length_eps": EFFECTIVE_LENGTH_EPS, "joint_share": JOINT_SHARE, "designs": list(names),
                "numerics": QUICK_NUMERICS}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
