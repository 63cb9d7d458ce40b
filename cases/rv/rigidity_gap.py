"""Audit of the RV rigidity gap (issue 30): every compliance member of rv40e and rv80e against an independent
closed form at its own load at T_R, and the b/a's dependence on the torque points the catalogue files do not give.

With every member on, the model's b/a is 185.3 (rv40e) and 326.6 (rv80e) N m/arcmin against the catalogue's 108 and
196 (``validate_rv``): 1.7x too stiff. This case looks for a defect in the members the model has. It does not fit
anything: every figure below is the model's as the design files and the members files (at the middles of their
ranges) give it, set beside a closed form computed here from the design's geometry and a cited formula.

Per design, the variants of ``cases/rv/compliance_budget.py``: ``all_rigid`` (the contact members only: pins,
needles, crank rows, involute stage, main bearings), ``elastic_cranks`` (the crank beam alone: no tilt, no
torsion) and ``ported_carrier``. At T_R (input angle 0) and T_R +- 1 % the static state gives each contact row's
normal force F_r and its derivative dF_r/dT (central difference); the model's compliance of a member is its energy
share times the output compliance (:func:`rvtool.protocols.budget.stiffness_budget`), in arcmin/(N m).

Checks (each with its tolerance and why; ``passed`` from these):

* ``*_law`` (pins, needles, crank rows): the member's energy sum_r (dF_r/dT)^2 / k_r with the tangent k_r of the
  cited law evaluated here, not by the model's law code: Palmgren's line contact delta = 3.84e-5 Q^0.9 / l^0.8
  [mm, N] (Palmgren, Ball and Roller Bearing Engineering, 3rd ed. 1959; Harris & Kotzalas, Essential Concepts of
  Bearing Technology, 5th ed. 2007), once per cycloid-pin contact (or the design's ``line`` secant at its
  reference force), twice per roller (both raceways) with the roller's law shared by its laminae in proportion
  to their length. Tolerance LAW_TOL: the central difference's truncation and the contact normals' turn.
* ``needles_stribeck`` / ``crank_rows_stribeck``: the textbook bearing stiffness at each bearing's radial resultant
  F_b (the rows' normal loads projected by cos alpha, alpha the cup angle for the tapered rows): the most loaded
  roller Q_max = 4.08 F_b / (Z cos alpha) (Stribeck's number for line contact at zero
  clearance, Harris & Kotzalas 2007, ch. 7), its approach delta_n = 2 x Palmgren, radial deflection delta_n /
  cos alpha, tangent k_b = (10/9) F_b / delta_r, and the member's compliance sum_b |dF_b/dT|^2 / k_b. Needles:
  within STRIBECK_TOL (the model has a radial clearance of 1.5 um, which raises Q_max over 4.08 F_b/Z, and
  discrete roller positions). Crank rows: within STRIBECK_TOL as well (their axial preload loads more rollers than
  Stribeck's zero-clearance count, so the model's Q_max lies below 4.08 F_b / (Z cos alpha); the bound holds the
  preload's effect at these radial loads).
* ``pins_fmax`` (rv40e only: no profile modification): the largest pin force against the classical
  F_max = 4 T_w / (K1 z_b r_p) with T_w = T_R / 2 per wheel (Li Lixing's cycloid load distribution, as in
  Blagojevic et al., Strojniski vestnik 57 (2011) 1): within PIN_FMAX_TOL (the classical form keeps the wheel's
  centre fixed; in the model the needles let it move, and T_w differs from T_R / 2 by the first stage's share).
* ``crank_beam``: the crank's bending and shear energy by virtual work on the simply supported Timoshenko beam
  (Cowper's shear coefficient), each journal's load (the eccentric bearings' resultant on that crank, its
  derivative along the torque) spread uniformly over the needle length and the deflection averaged over it,
  computed here by quadrature, against the model's crank share: within BEAM_TOL (the spur gear's force is left
  out here). Point loads instead would be 12-14 % stiffer at the journals than the spread loads (measured with
  this function): the load's spread is part of the member, not a detail.
* ``carrier_pillars``: a lower bound. The end plate's half of each crank seat's load reaches the output flange
  only through the pillars; a pillar as a fixed-guided Timoshenko beam (the stiffest its plates can hold it)
  gives C_pillars = (1/2)^2 / (n_p k_p R_p^2). The model's carrier compliance (FE) must be >= it (ratio >= 1).
* ``carrier_seats`` (reported; one check): the same seat loads on the carrier's parent FE through the model's
  uniform seat ports (their energy must equal the model's carrier share within PORT_TOL: a check of the audit's
  load extraction) and as a cosine pressure on the loaded half of each seat bore (a cup loose in its bore; the
  model's port is nearer a press-fitted cup, whose fit the files do not state): the ratio is the carrier's
  compliance factor between the two readings.
* ``housing_mounts``: a lower bound and a split. The ported housing is held on ``n_mounts`` springs of
  ``mount_stiffness`` per direction on ``mount_radius`` (rv40e.toml / rv80e.toml [housing.structure]; the value is
  chosen/assumed, no source): the whole output torque passes them, C_mounts = 1 / (n_m k_m R_m^2). The model's
  housing compliance (``ported_housing`` variant) must be >= it; the ratio says how much of the housing member is
  the assumed mounting rather than the annulus.

The b/a on other torque points (``ba_points``): the catalogue files leave the b/a torque points out (they were not
read: ``rv40e_catalogue.toml`` / ``rv80e_catalogue.toml`` [test]); validate uses the stated convention 50-100 %
T_R. Here the b/a of the ``all_rigid`` variant at (T_1, T_R) for T_1 in BA_LOW_POINTS shows how much the choice can
move the figure (the contact members carry all of the model's nonlinearity; the linear FE members only dilute it).
Reported, not a criterion.

--quick: the carrier and the housing at 8 mm tetrahedra (the files: 5-6 mm); the full run uses the files' meshes
and adds ``ba_points_all_on``: the same b/a points on the all-members-on design of ``rvtool validate`` (the members
files at their middles, validate's --quick meshes, so that its 0.5-1 entry is validate's central value).
"""
import math
import os
import re
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver
from rvtool.solver.torque_path import ContinuationPath
from rvtool.units import RAD_PER_ARCMIN

DESIGNS = ("rv40e", "rv80e")
PALMGREN = 3.84e-5
"""Palmgren's line-contact constant: delta [mm] = 3.84e-5 Q^0.9 / l^0.8 (Q [N], l [mm]) per contact (Palmgren
1959; Harris & Kotzalas 2007)."""
STRIBECK_LINE = 4.08
"""Q_max = 4.08 F_r / (Z cos alpha): line contact, zero clearance (Stribeck; Harris & Kotzalas 2007, ch. 7)."""
DERIV_STEP = 0.01
"""dF/dT by central differences over T_R (1 +- 0.01): truncation O(0.01^2) of a smooth power law."""
LAW_TOL = 0.02
"""Law check: the member's energy from its rows' dF/dT and the cited law's tangent vs the budget's share: the
central difference's truncation (1e-4) and the turn of the contact normals along the mode (the budget's
geometric entry, < 1e-3 of C): 2 %."""
STRIBECK_TOL = 0.25
"""Textbook bearing stiffness: Stribeck's 4.08 holds at zero clearance; Harris gives about 5 for a typical small
clearance (a 23 % larger Q_max, ~20 % in deflection), plus the discrete roller positions: 25 %."""
PIN_FMAX_TOL = 0.20
"""Classical F_max: the wheel centre held fixed (the model's needles let it move a few um, re-sharing the load) and
T_w = T_R / 2 (the first stage carries a few per cent): 20 %."""
BEAM_TOL = 0.10
"""The spur gear's force left out: about 6 % of a journal's load on the overhang, up to ~4 % of the beam's energy
through its cross term with the journals (the integration is exact): 10 %."""
BEAM_POINTS = 21
"""Quadrature points over each journal's needle length (the spread load and the station mean)."""
BA_LOW_POINTS = (0.5, 0.25, 0.1, 0.03)
"""Lower torque points T_1 / T_R of the b/a (upper point T_R): 0.5 is validate's stated convention; 0.03 is the
lost-motion torque (the lower end of the region the catalogue's lost motion is read in)."""
PORT_TOL = 1e-3
"""The carrier's port energy from the rows' dF/dT on the parent FE vs the model's carrier share: the reduced static
port compliance equals the parent's to ~1e-12 (carrier_body), the central difference's truncation is ~1e-4."""
QUICK_MESH = 0.008
"""--quick: carrier and housing tetrahedra of 8 mm (as compliance_budget --quick)."""
OFF = {"cranks": {"shaft": {"model": "rigid", "tilt": False, "torsion": "rigid"}}, "housing": {"model": "rigid"},
       "carrier": {"body": "rigid"}, "wheels": {"body": "rigid"}, "pins": {"groove": "rigid"}}


def arcmin_per_Nm(c_rad_per_Nm):
    return c_rad_per_Nm / RAD_PER_ARCMIN


# --- the cited laws, written here (not the model's law code) -----------------------------------------------------
def palmgren_delta(Q, l):
    """Approach [m] of one steel line contact under Q [N] over length l [m] (Palmgren)."""
    return PALMGREN * np.asarray(Q, float) ** 0.9 / (l * 1e3) ** 0.8 * 1e-3


def palmgren_tangent(Q, l, contacts=1):
    """dQ/d delta [N/m] of ``contacts`` Palmgren contacts in series at load Q (p = 10/9: k_t = (10/9) Q / delta)."""
    Q = np.asarray(Q, float)
    return (10.0 / 9.0) * Q / (contacts * palmgren_delta(Q, l))


def lamina_tangent(F, roller_length, n_slices):
    """Tangent [N/m] of a lamina carrying F of a roller whose Palmgren law (both raceways) is shared by its
    n_slices laminae in proportion to their length (a uniform approach loads the roller as the unsliced law):
    F = (k_roller / n) delta^(10/9), k_roller from 2 x Palmgren over the whole roller."""
    return palmgren_tangent(np.asarray(F, float) * n_slices, roller_length, contacts=2) / n_slices


# --- model states -----------------------------------------------------------------------------------------------
class State:
    """The model's static state at T_R and its rows' dF/dT (module docstring)."""

    def __init__(self, design):
        self.design = design
        self.model = m = rvtool.build(design)
        self.sign = -np.sign(m.ratio)
        T = design.rated_torque
        self.q = self._solve(T)
        self.budget = stiffness_budget(m, self.q)
        self.K_t = float(self.budget["K_t_Nm_per_arcmin"])
        self.C = 1.0 / self.K_t
        self.obs = {f.value: m.observe(self.q, f) for f in m.families}
        h = DERIV_STEP * T
        plus = self._observe(T + h)
        minus = self._observe(T - h)
        self.dF = {k: (plus[k].normal_force - minus[k].normal_force) / (2 * h) for k in self.obs}
        self.dvec = {k: (_vectors(plus[k]) - _vectors(minus[k])) / (2 * h) for k in self.obs}
        self._solve(T)

    def _solve(self, T):
        self.model.set_output_torque(self.sign * T)
        return StaticSolver(self.model).solve(0.0)

    def _observe(self, T):
        q = self._solve(T)
        return {f.value: self.model.observe(q, f) for f in self.model.families}

    def member_compliance(self, path):
        """The model's compliance of a budget path [arcmin/(N m)]: energy share x C."""
        return float(self.budget["shares"].get(path, 0.0)) * self.C


def _vectors(o):
    return o.normal_force[:, None] * np.asarray(o.normal)[:, :2]


def group(ids, pattern):
    """{group key: row indices} of ids matching ``pattern`` (its first group is the key)."""
    out = {}
    for i, s in enumerate(ids):
        mm = re.match(pattern, s)
        if mm:
            out.setdefault(mm.group(1), []).append(i)
    return out


# --- checks --------------------------------------------------------------------------------------------------------
def pins_law(s):
    d = s.design
    o, dF = s.obs["pins"], s.dF["pins"]
    L = d.wheels.width / d.wheels.n_slices
    F = o.normal_force
    on = F > 0
    if d.pin_contact.law == "palmgren":
        k = palmgren_tangent(F[on], L)
        law = "Palmgren line contact, once per cycloid-pin contact (tangent at each pin's load)"
    elif d.pin_contact.law == "line":
        k = np.full(on.sum(), d.pin_contact.reference_force / palmgren_delta(d.pin_contact.reference_force, L))
        law = (f"the design's 'line' law: Palmgren's secant at reference_force = {d.pin_contact.reference_force:g} N "
               "(a linear spring)")
    else:
        return {"note": f"pin law {d.pin_contact.law!r} not audited"}
    cf = arcmin_per_Nm(float(np.sum(dF[on] ** 2 / k)))
    model = s.member_compliance("pins")
    return {"law": law, "model_arcmin_per_Nm": model, "closed_form_arcmin_per_Nm": cf, "ratio": model / cf,
            "loaded_pins": int(on.sum()), "rows": int(len(F)), "max_pin_force_N": float(F.max())}


def pins_fmax(s):
    d = s.design
    T_w = 0.5 * d.rated_torque
    K1 = d.wheels.eccentricity * d.pins.n_pins / d.pins.pin_circle_radius
    F_cl = 4.0 * T_w / (K1 * d.pins.n_pins * d.pins.pin_circle_radius)
    Fm = float(s.obs["pins"].normal_force.max())
    return {"model_N": Fm, "classical_N": F_cl, "ratio": Fm / F_cl, "K1": K1,
            "formula": "F_max = 4 T_w / (K1 z_b r_p), T_w = T_R / 2 (unmodified profile, rigid wheel centre)"}


def bearing_law(s, family, roller_length, n_slices):
    F, dF = s.obs[family].normal_force, s.dF[family]
    on = F > 0
    cf = arcmin_per_Nm(float(np.sum(dF[on] ** 2 / lamina_tangent(F[on], roller_length, n_slices))))
    model = s.member_compliance(family)
    return {"model_arcmin_per_Nm": model, "closed_form_arcmin_per_Nm": cf, "ratio": model / cf,
            "loaded_laminae": int(on.sum()), "laminae": int(len(F))}


def bearing_stribeck(s, family, pattern, n_rollers, roller_length, alpha):
    """Textbook (Stribeck + Palmgren) compliance of a family of bearings from each bearing's resultant. The rows
    observe the roller's normal load Q along the planar radial direction; a row at contact angle alpha carries
    Q cos(alpha) radially (the tapered rows: the cup angle; checked by the carrier's port energy, which equals the
    model's carrier share with this projection)."""
    o = s.obs[family]
    vec, dvec = math.cos(alpha) * _vectors(o), math.cos(alpha) * s.dvec[family]
    groups = group(o.ids, pattern)
    c_cf, rows = 0.0, {}
    for key, idx in groups.items():
        Fb = vec[idx].sum(axis=0)
        dFb = dvec[idx].sum(axis=0)
        Fmag = float(np.hypot(*Fb))
        Q_max = STRIBECK_LINE * Fmag / (n_rollers * math.cos(alpha))
        delta_r = 2 * float(palmgren_delta(Q_max, roller_length)) / math.cos(alpha)
        k_b = (10.0 / 9.0) * Fmag / delta_r
        c_cf += float(dFb @ dFb) / k_b
        # the model's most loaded roller (its laminae summed)
        rl = {}
        for i in idx:
            r = o.ids[i].rsplit("/", 1)[0]
            rl[r] = rl.get(r, 0.0) + o.normal_force[i]
        rows[key] = {"F_b_N": Fmag, "Q_max_stribeck_N": Q_max, "Q_max_model_N": max(rl.values()),
                     "k_b_N_per_m": k_b,
                     "dF_angle_to_F_deg": math.degrees(math.acos(max(-1.0, min(1.0, float(
                         Fb @ dFb) / (Fmag * math.hypot(*dFb) + 1e-300)))))}
    cf = arcmin_per_Nm(c_cf)
    model = s.member_compliance(family)
    return {"model_arcmin_per_Nm": model, "closed_form_arcmin_per_Nm": cf, "ratio": model / cf, "bearings": rows}


def beam_flexibility(z_loads, supports, radius, E, nu):
    """A [m/N]: deflection at z_i relative to the line through the supports under a unit point load at z_j, by
    virtual work on the simply supported (overhang allowed) Timoshenko beam of a solid circle:
    a_ij = int M_i M_j / EI dz + int V_i V_j / (kappa G A) dz (kappa: Cowper's 6(1+nu)/(7+6nu)), integrated
    exactly: between consecutive breakpoints (supports and load points) M is linear (Simpson's rule is exact for
    the products) and V is constant (its midpoint value)."""
    za, zb = supports
    I = math.pi * radius ** 4 / 4
    A = math.pi * radius ** 2
    G = E / (2 * (1 + nu))
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    L = zb - za
    br = np.unique(np.array(list(z_loads) + [za, zb], float))
    a, b = br[:-1], br[1:]
    m = 0.5 * (a + b)

    def MV(zp, z):
        # unit load at zp, reactions at za, zb (statics); M and V at z (left of a breakpoint: its left value)
        Rb = (zp - za) / L
        Ra = 1.0 - Rb
        M = np.zeros_like(z)
        V = np.zeros_like(z)
        for zf, f in ((za, Ra), (zb, Rb), (zp, -1.0)):
            right = z > zf
            M[right] += f * (z[right] - zf)
            V[right] += f
        return M, V

    w = (b - a) / 6.0
    parts = [(MV(zp, a)[0], MV(zp, m), MV(zp, b)[0]) for zp in z_loads]
    out = np.zeros((len(z_loads), len(z_loads)))
    for i, (Mai, (Mmi, Vmi), Mbi) in enumerate(parts):
        for j, (Maj, (Mmj, Vmj), Mbj) in enumerate(parts):
            out[i, j] = (np.sum(w * (Mai * Maj + 4 * Mmi * Mmj + Mbi * Mbj)) / (E * I)
                         + np.sum((b - a) * Vmi * Vmj) / (kappa * G * A))
    return out


def spread_flexibility(z_centres, width, supports, radius, E, nu, n=BEAM_POINTS):
    """A [m/N] between stations of ``width`` centred at ``z_centres``: the mean deflection over station i under a
    unit resultant spread uniformly over station j (:func:`beam_flexibility` at n points per station)."""
    pts = np.concatenate([np.linspace(z - width / 2, z + width / 2, n) for z in z_centres])
    B = beam_flexibility(list(pts), supports, radius, E, nu)
    S = np.kron(np.eye(len(z_centres)), np.full((1, n), 1.0 / n))
    return S @ B @ S.T


def crank_beam(s):
    d = s.design
    sh = d.cranks.shaft
    mid = 0.5 * sum(sh.supports)
    supports = tuple(x - mid for x in sh.supports)
    z_j = [z - mid for z in d.wheels.midplanes]
    A = spread_flexibility(z_j, d.eccentric_bearing.roller_length, supports, sh.radius, d.material.youngs_modulus,
                           d.material.poisson_ratio)
    A_point = beam_flexibility(z_j, supports, sh.radius, d.material.youngs_modulus, d.material.poisson_ratio)
    o = s.obs["eccentric_bearings"]
    groups = group(o.ids, r"eccentric_bearing_c(\d+w\d+)/")
    dvec = s.dvec["eccentric_bearings"]
    c = c_point = 0.0
    for k in range(d.cranks.count):
        dP = np.array([dvec[groups[f"{k}w{w}"]].sum(axis=0) for w in range(len(d.wheels.midplanes))])
        c += sum(float(dP[:, a] @ A @ dP[:, a]) for a in range(2))
        c_point += sum(float(dP[:, a] @ A_point @ dP[:, a]) for a in range(2))
    cf = arcmin_per_Nm(c)
    model = s.member_compliance("cranks")
    return {"model_arcmin_per_Nm": model, "closed_form_arcmin_per_Nm": cf, "ratio": model / cf,
            "point_load_closed_form_arcmin_per_Nm": arcmin_per_Nm(c_point),
            "journal_positions_m": z_j, "load_width_m": d.eccentric_bearing.roller_length,
            "supports_m": list(supports), "radius_m": sh.radius}


def pillar_stiffness(d):
    """Shear stiffness [N/m] of one carrier pillar as a fixed-guided Timoshenko beam of a solid circle between the
    plates' inner faces (the stiffest hold its plates can give it)."""
    cs = d.carrier.structure
    E, nu = d.material.youngs_modulus, d.material.poisson_ratio
    L = 2 * cs.inner_face_position
    r = cs.pillar_radius
    I, A, G = math.pi * r ** 4 / 4, math.pi * r ** 2, E / (2 * (1 + nu))
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    return 1.0 / (L ** 3 / (12 * E * I) + L / (kappa * G * A))


def carrier_pillars(s):
    d = s.design
    cs = d.carrier.structure
    L = 2 * cs.inner_face_position
    k_p = pillar_stiffness(d)
    n_p = d.cranks.count
    c_bound = arcmin_per_Nm(0.25 / (n_p * k_p * cs.pillar_circle_radius ** 2))
    model = s.member_compliance("carrier")
    return {"model_arcmin_per_Nm": model, "pillar_bound_arcmin_per_Nm": c_bound, "ratio": model / c_bound,
            "pillar_shape": cs.pillar_shape, "pillar_length_m": L, "pillar_k_N_per_m": k_p,
            "note": "fixed-guided pillars carrying the end plate's half of the seat loads: a lower bound"}


def carrier_seats(s):
    """The carrier's seat load distribution. The model's crank ports spread a seat's load uniformly over the whole
    seat bore (an RBE3-type mean, rvtool.structure.carrier); a bearing cup pushes on the loaded arc only unless its
    press fit holds the whole bore. On the parent FE: the energy of the seat loads' derivatives dF_k/dT (the crank
    rows' radial resultants) (i) through the model's ports, which must equal the model's carrier share, and (ii) as
    a radial cosine pressure p ~ max(0, e_r . d) on the half bore the load d points to (half per plate; both signs
    of d, as the seat's surroundings are not symmetric). The ratio (ii)/(i) is the factor on the carrier's
    compliance if the cups sat loose in their bores."""
    import ngsolve as ngs
    from rvtool.assembly.carrier import carrier_layout
    from rvtool.structure.carrier import carrier_fe
    d = s.design
    alpha = d.crank_bearing.rows[0].cup_angle
    o = s.obs["crank_bearings"]
    dvec = math.cos(alpha) * s.dvec["crank_bearings"]
    grp = group(o.ids, r"crank_bearing(\d+)/")
    r, angles, _, _ = carrier_layout(d)
    fe = carrier_fe(d.carrier.structure, d.material if d.carrier.structure.material is None
                    else d.carrier.structure.material, r, angles)
    P = fe.port_matrix.toarray()
    rigid = fe.rigid_modes((0.0, 0.0, 0.0))[:, :2]
    f_port = np.zeros(fe.n_dofs)
    f_cos = {1: np.zeros(fe.n_dofs), -1: np.zeros(fe.n_dofs)}
    for k, ang in enumerate(angles):
        dF = dvec[grp[str(k)]].sum(axis=0)
        f_port += P[2 * k:2 * k + 2].T @ dF
        cx, cy = r * math.cos(ang), r * math.sin(ang)
        rho = ngs.sqrt((ngs.x - cx) ** 2 + (ngs.y - cy) ** 2)
        erx, ery = (ngs.x - cx) / rho, (ngs.y - cy) / rho
        for sg in (1, -1):
            dirn = sg * dF / math.hypot(*dF)
            c = erx * float(dirn[0]) + ery * float(dirn[1])
            p = ngs.IfPos(c, c, 0.0)
            traction = ngs.CoefficientFunction((p * erx, p * ery, 0.0))
            for seat in (f"crank{k}_flange", f"crank{k}_end_plate"):
                f = fe.forms.form(traction, (seat,))
                resultant = float((rigid.T @ f) @ dirn)
                f_cos[sg] += sg * (0.5 * math.hypot(*dF) / resultant) * f
    e_port = arcmin_per_Nm(float(f_port @ fe.solve(f_port)))
    e_cos = {sg: arcmin_per_Nm(float(v @ fe.solve(v))) for sg, v in f_cos.items()}
    model = s.member_compliance("carrier")
    return {"model_arcmin_per_Nm": model, "port_energy_arcmin_per_Nm": e_port,
            "port_energy_rel_err": abs(e_port - model) / model,
            "cosine_half_bore_arcmin_per_Nm": e_cos[1], "cosine_half_bore_reversed_arcmin_per_Nm": e_cos[-1],
            "cosine_to_port_ratio": e_cos[1] / e_port, "cosine_reversed_to_port_ratio": e_cos[-1] / e_port,
            "mesh": fe.counts}


def housing_mounts(s):
    hs = s.design.housing.structure
    c_mounts = arcmin_per_Nm(1.0 / (hs.n_mounts * hs.mount_stiffness * hs.mount_radius ** 2))
    model = s.member_compliance("housing_ports")
    return {"model_arcmin_per_Nm": model, "mounts_arcmin_per_Nm": c_mounts, "ratio": model / c_mounts,
            "mounts_share_of_housing_member": c_mounts / model, "n_mounts": hs.n_mounts,
            "mount_stiffness_N_per_m": hs.mount_stiffness, "mount_radius_m": hs.mount_radius}


def all_on_design(name):
    """The all-members-on design of ``rvtool validate`` (members file at the middles, validate's quick meshes)."""
    from rvtool.analysis.validate_members import QUICK_NUMERICS, load_members, members_name, members_table
    from rvtool.assembly.topologies import design_from_table, read_table
    switches, derived, assumed, _ = load_members(members_name(name))
    mid = {a.key: a.middle for a in assumed.inputs}
    return design_from_table(members_table(read_table(designs.path(name)), switches, derived, mid, QUICK_NUMERICS))


def ba_points(design):
    """b/a [N m/arcmin] at (T_1, T_R) for T_1 / T_R in BA_LOW_POINTS (both signs, the mean), one loading path."""
    T = design.rated_torque
    path = ContinuationPath(rvtool.build(design))
    levels = sorted(set(BA_LOW_POINTS) | {1.0})
    ang = {}
    for sgn in (1.0, -1.0):
        for f in levels:
            ang[(sgn, f)] = path.go_to(sgn * f * T)
    out = {}
    for f in BA_LOW_POINTS:
        per = [(1.0 - f) * T / (s * (ang[(s, 1.0)] - ang[(s, f)])) for s in (1.0, -1.0)]
        out[f"{f:g}-1"] = float(np.mean(per)) * RAD_PER_ARCMIN
    out["ratio_to_0.5-1"] = {k: v / out["0.5-1"] for k, v in out.items() if k != "ratio_to_0.5-1"}
    return out


def audit(name, quick):
    t0 = time.perf_counter()
    d = rvtool.load_design(designs.path(name))
    rigid = State(d.replace(**OFF))
    eb, cb = d.eccentric_bearing, d.crank_bearing
    row = cb.rows[0]
    alpha = row.cup_angle          # the cup (outer race, in the carrier) angle: the row's radial projection
    out = {"K_t_all_rigid_Nm_per_arcmin": rigid.K_t,
           "pins_law": pins_law(rigid),
           "needles_law": bearing_law(rigid, "eccentric_bearings", eb.roller_length, eb.n_slices),
           "crank_rows_law": bearing_law(rigid, "crank_bearings", row.roller_length, row.n_slices),
           "needles_stribeck": bearing_stribeck(rigid, "eccentric_bearings", r"(eccentric_bearing_c\d+w\d+)/",
                                                eb.n_rollers, eb.roller_length, 0.0),
           "crank_rows_stribeck": bearing_stribeck(rigid, "crank_bearings", r"(crank_bearing\d+/row\d+)/",
                                                   row.n_rollers, row.roller_length, alpha)}
    out["crank_rows_stribeck"]["contact_angle_deg"] = math.degrees(alpha)
    out["crank_rows_stribeck"]["axial_preload_N"] = cb.axial_preload
    if d.profile is None or (d.profile.equidistant_mod == 0 and d.profile.offset_mod == 0):
        out["pins_fmax"] = pins_fmax(rigid)
    else:
        out["pins_fmax_not_checked"] = "modified profile: the classical distribution does not hold"
        out["max_pin_force_N"] = float(rigid.obs["pins"].normal_force.max())
    sh = d.source["cranks"].get("shaft", {})
    beam_table = {"model": "simply_supported", "tilt": False, "torsion": "rigid"}
    for k in ("radius", "supports", "gear_position"):
        if k in sh:
            beam_table[k] = sh[k]
    cranks = State(d.replace(**{**OFF, "cranks": {"shaft": beam_table}}))
    out["crank_beam"] = crank_beam(cranks)
    carrier_on = {"body": "ported", **({"structure": {"mesh_size": QUICK_MESH}} if quick else {})}
    carrier = State(d.replace(**{**OFF, "carrier": carrier_on}))
    out["carrier_pillars"] = carrier_pillars(carrier)
    out["carrier_seats"] = carrier_seats(carrier)
    housing_on = {"model": "ports", **({"structure": {"mesh_size": QUICK_MESH}} if quick else {})}
    out["housing_mounts"] = housing_mounts(State(d.replace(**{**OFF, "housing": housing_on})))
    out["table"] = summary_table(out)
    out["ba_points_all_rigid"] = ba_points(d.replace(**OFF))
    if not quick:
        out["ba_points_all_on"] = ba_points(all_on_design(name))
    out["wall_s"] = time.perf_counter() - t0
    return out


SOURCES = {
    "pins": ("law", "pins_law", "Palmgren 1959 line contact (or the design's line secant), tangent at each pin's load"),
    "eccentric_bearings": ("textbook", "needles_stribeck", "Stribeck Q_max = 4.08 F/Z + Palmgren on both raceways "
                                                           "(Harris & Kotzalas 2007)"),
    "crank_bearings": ("textbook", "crank_rows_stribeck", "as the needles with the cup angle alpha "
                                                          "(Q_max = 4.08 F/(Z cos alpha)), no preload"),
    "cranks": ("closed form", "crank_beam", "simply supported Timoshenko beam, virtual work, journal loads spread "
                                            "over the needle length"),
    "carrier": ("lower bound", "carrier_pillars", "pillars as fixed-guided Timoshenko beams carrying the end "
                                                  "plate's half of the seat loads"),
    "housing_ports": ("lower bound", "housing_mounts", "the housing's mount springs alone (n k R^2); their "
                                                       "stiffness is chosen/assumed, no source"),
}


def summary_table(a):
    """One row per member: the model's compliance, the independent one, their ratio, the kind and source."""
    out = {}
    for member, (kind, key, source) in SOURCES.items():
        e = a[key]
        ind = e.get("closed_form_arcmin_per_Nm", e.get("pillar_bound_arcmin_per_Nm", e.get("mounts_arcmin_per_Nm")))
        out[member] = {"model_arcmin_per_Nm": e["model_arcmin_per_Nm"], "independent_arcmin_per_Nm": ind,
                       "ratio_model_to_independent": e["ratio"], "kind": kind, "source": source}
    return out


def judge(r):
    c = {}
    for name, a in r["designs"].items():
        for k in ("pins_law", "needles_law", "crank_rows_law"):
            if "ratio" in a[k]:
                c[f"{name}_{k}"] = casekit.check(abs(a[k]["ratio"] - 1.0), LAW_TOL, "<=",
                                                 "the cited law's energy vs the budget's share (LAW_TOL)")
        c[f"{name}_needles_stribeck"] = casekit.check(abs(a["needles_stribeck"]["ratio"] - 1.0), STRIBECK_TOL, "<=",
                                                      "textbook needle bearing stiffness (STRIBECK_TOL)")
        c[f"{name}_crank_rows_stribeck"] = casekit.check(abs(a["crank_rows_stribeck"]["ratio"] - 1.0), STRIBECK_TOL,
                                                         "<=", "textbook tapered row stiffness, no preload "
                                                         "(STRIBECK_TOL)")
        if "pins_fmax" in a:
            c[f"{name}_pins_fmax"] = casekit.check(abs(a["pins_fmax"]["ratio"] - 1.0), PIN_FMAX_TOL, "<=",
                                                   "classical cycloid load distribution (PIN_FMAX_TOL)")
        c[f"{name}_crank_beam"] = casekit.check(abs(a["crank_beam"]["ratio"] - 1.0), BEAM_TOL, "<=",
                                                "spread-load Timoshenko beam by virtual work (BEAM_TOL)")
        c[f"{name}_carrier_pillars"] = casekit.check(a["carrier_pillars"]["ratio"], 1.0, ">=",
                                                     "the carrier FE at least as compliant as its pillars alone")
        c[f"{name}_carrier_port_energy"] = casekit.check(a["carrier_seats"]["port_energy_rel_err"], PORT_TOL, "<=",
                                                         "the seat loads through the parent's ports reproduce the "
                                                         "model's carrier share (PORT_TOL)")
        c[f"{name}_housing_mounts"] = casekit.check(a["housing_mounts"]["ratio"], 1.0, ">=",
                                                    "the housing member at least as compliant as its mounts alone")
    return c


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    results = {"designs": {n: audit(n, args.quick) for n in DESIGNS}}
    casekit.verdict(results, judge)
    settings = {"quick": args.quick, "carrier_mesh_quick_m": QUICK_MESH, "deriv_step": DERIV_STEP,
                "tolerances": {"law": LAW_TOL, "stribeck": STRIBECK_TOL, "pin_fmax": PIN_FMAX_TOL, "beam": BEAM_TOL},
                "ba_low_points": list(BA_LOW_POINTS)}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
