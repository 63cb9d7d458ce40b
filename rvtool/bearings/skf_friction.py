"""Bearing friction moment with SKF's 2004 model: a second, independent rolling-bearing friction model
beside Palmgren's (:mod:`rvtool.bearings.friction_torque`), for the model-form spread of the efficiency
(issue 30, Deliver 2 audit). It is a reference model: the pre-committed friction set stays Palmgren's.

Source [SKF04]: SKF General Catalogue 6000 EN (the friction chapter, "The new SKF model for calculation of
the frictional moment", introduced with the 2004 catalogue; the same model in the SKF Rolling bearings
catalogue 10000 EN, 2018). The model, in the catalogue's units (M [N mm], n [r/min], nu [mm^2/s], d_m, d,
D [mm], F [N]):

    M    = phi_ish phi_rs M_rr + M_sl + M_seal + M_drag
    M_rr = G_rr (nu n)^0.6                                        rolling frictional moment
    M_sl = G_sl mu_sl                                              sliding frictional moment
    phi_ish = 1 / (1 + 1.84e-9 (n d_m)^1.28 nu^0.64)               inlet shear heating reduction
    phi_rs  = exp(-K_rs nu n (d + D) sqrt(K_Z / (2 (D - d))))      kinematic replenishment/starvation
    mu_sl   = phi_bl mu_bl + (1 - phi_bl) mu_EHL,  phi_bl = exp(-2.6e-8 (n nu)^1.4 d_m)

with K_rs = 6e-8 for grease and oil-air (3e-8 for a low-level oil bath and oil jet), mu_bl = 0.12 (n > 0),
mu_EHL = 0.05 for mineral oils (0.02 for cylindrical and tapered roller bearings). G_rr and G_sl by
bearing type (Table 2a; forms read in the excerpt of the SKF Rolling bearings catalogue's friction
chapter, Table 2a):

    cylindrical roller   G_rr = R1 d_m^2.41 F_r^0.31               G_sl = S1 d_m^0.9 F_a + S2 d_m F_r
    tapered roller       G_rr = R1 d_m^2.38 (F_r + R2 Y F_a)^0.31  G_sl = S1 d_m^0.82 (F_r + S2 Y F_a)
    angular contact ball G_rr = R1 d_m^1.97 (F_r + F_g + R2 F_a)^0.54, F_g = R3 d_m^4 n^2
                         G_sl = S1 d_m^0.26 ((F_r + F_g)^(4/3) + S2 F_a^(4/3)), F_g = S3 d_m^4 n^2

The constants R, S (Table 2b, per series) and K_Z (per type) are in :data:`CONSTANTS` with their source and
reading status. M_seal = 0 (open bearings: the reducer's lip seal is a part of its own in the loss
accounting); M_drag = 0 (SKF's drag term is for oil-bath lubrication; the RV E series is grease-filled).

The functions take SI (m, rad/s, m^2/s, N) and return N m; the conversions are named constants.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive
# the catalogue's units (mm, mm^2/s, r/min, N mm): the same conversions as Palmgren's model
from .friction_torque import MM2_S_PER_M2_S, MM_PER_M, NM_PER_NMM, RPM_PER_RAD_S

#: phi_ish = 1 / (1 + ISH_C (n d_m)^ISH_A nu^ISH_B) [SKF04]
ISH_C, ISH_A, ISH_B = 1.84e-9, 1.28, 0.64
#: K_rs [SKF04]: grease and oil-air; low-level oil bath and oil jet
K_RS = {"grease": 6e-8, "oil_air": 6e-8, "oil_bath": 3e-8, "oil_jet": 3e-8}
#: phi_bl = exp(-BL_C (n nu)^BL_A d_m) [SKF04]
BL_C, BL_A = 2.6e-8, 1.4
#: boundary-lubrication mu_bl for n > 0 [SKF04]
MU_BL = 0.12
#: rolling exponent of (nu n) [SKF04]
RR_EXPONENT = 0.6


@dataclass(frozen=True)
class SkfConstants:
    """One bearing kind of [SKF04]: ``form`` ("cylindrical_roller", "tapered_roller",
    "angular_contact_ball"), the Table 2b constants R1..S3 (0 where the form has none), K_Z, mu_EHL for
    a mineral base oil, the source and its reading status."""
    form: str
    R1: float
    R2: float
    R3: float
    S1: float
    S2: float
    S3: float
    K_Z: float
    mu_ehl: float
    source: str
    status: str


#: The kinds the RV reducers use. Every constant [SKF04], status "not_reread" (values as known to the
#: writer; the catalogue pages reachable here showed the formula forms of Table 2a and Table 1, not the
#: constants of Table 2b). A needle roller set on a journal (caged, no rings) has no row of its own in the
#: 2004 General Catalogue: it takes the cylindrical roller form with the series-2 constants (`assumed`: a
#: caged line-contact roller set; over the catalogue's caged series 2-23, R1 spans 0.96e-6 to 1.48e-6) and
#: K_Z of the cylindrical roller bearing with a cage.
CONSTANTS = {
    "needle_roller": SkfConstants("cylindrical_roller", 1.09e-6, 0.0, 0.0, 0.16, 0.0015, 0.0, 5.1, 0.02,
                                  "[SKF04] Table 2b cylindrical roller bearings, series 2 (assumed for a caged "
                                  "needle set); K_Z cylindrical roller with cage", "not_reread"),
    "tapered_roller_302": SkfConstants("tapered_roller", 1.76e-6, 10.9, 0.0, 0.017, 2.0, 0.0, 6.0, 0.02,
                                       "[SKF04] Table 2b tapered roller bearings, series 302; K_Z tapered roller",
                                       "not_reread"),
    "angular_contact_72B": SkfConstants("angular_contact_ball", 5.03e-7, 1.97, 1.90e-12, 1.30e-2, 0.68,
                                        1.91e-12, 4.4, 0.05,
                                        "[SKF04] Table 2b angular contact ball bearings, series 72 B; K_Z single "
                                        "row angular contact", "not_reread"),
}


def inlet_shear_factor(n_rpm, dm_mm, nu_mm2_s):
    """phi_ish [-] at n [r/min], d_m [mm], nu [mm^2/s] (catalogue units, module docstring)."""
    return 1.0 / (1.0 + ISH_C * (np.asarray(n_rpm, float) * dm_mm) ** ISH_A * nu_mm2_s ** ISH_B)


def replenishment_factor(n_rpm, nu_mm2_s, d_mm, D_mm, K_Z, lubrication="grease"):
    """phi_rs [-] (kinematic replenishment/starvation) at n [r/min], nu [mm^2/s], bore d and outside
    diameter D [mm] (D > d), K_Z; ``lubrication`` one of :data:`K_RS`."""
    if lubrication not in K_RS:
        raise RvtoolInputError(f"lubrication = {lubrication!r}; valid choices are {sorted(K_RS)}")
    if not D_mm > d_mm > 0:
        raise RvtoolInputError(f"ring diameters d = {d_mm} mm, D = {D_mm} mm are outside the valid range 0 < d < D")
    return np.exp(-K_RS[lubrication] * nu_mm2_s * np.asarray(n_rpm, float) * (d_mm + D_mm)
                  * math.sqrt(K_Z / (2.0 * (D_mm - d_mm))))


def sliding_mu(n_rpm, nu_mm2_s, dm_mm, mu_ehl):
    """mu_sl = phi_bl mu_bl + (1 - phi_bl) mu_EHL [-] (n > 0)."""
    phi_bl = np.exp(-BL_C * (np.asarray(n_rpm, float) * nu_mm2_s) ** BL_A * dm_mm)
    return phi_bl * MU_BL + (1.0 - phi_bl) * mu_ehl


def geometry_variables(c: SkfConstants, dm_mm, n_rpm, Fr, Fa=0.0, Y=None):
    """(G_rr, G_sl) of Table 2a for the form of ``c`` at d_m [mm], n [r/min], F_r, F_a [N]; Y the
    tapered row's axial load factor."""
    if c.form == "cylindrical_roller":
        return c.R1 * dm_mm ** 2.41 * Fr ** 0.31, c.S1 * dm_mm ** 0.9 * Fa + c.S2 * dm_mm * Fr
    if c.form == "tapered_roller":
        if Y is None or not Y > 0:
            raise RvtoolInputError(f"Y = {Y!r}: a tapered row needs its axial load factor Y > 0")
        return (c.R1 * dm_mm ** 2.38 * (Fr + c.R2 * Y * Fa) ** 0.31,
                c.S1 * dm_mm ** 0.82 * (Fr + c.S2 * Y * Fa))
    if c.form == "angular_contact_ball":
        fg_r, fg_s = c.R3 * dm_mm ** 4 * n_rpm ** 2, c.S3 * dm_mm ** 4 * n_rpm ** 2
        return (c.R1 * dm_mm ** 1.97 * (Fr + fg_r + c.R2 * Fa) ** 0.54,
                c.S1 * dm_mm ** 0.26 * ((Fr + fg_s) ** (4.0 / 3.0) + c.S2 * Fa ** (4.0 / 3.0)))
    raise RvtoolInputError(f"form = {c.form!r}; valid: cylindrical_roller, tapered_roller, angular_contact_ball")


def skf_moment(c: SkfConstants, *, speed, pitch_diameter, bore, outside, viscosity, radial_load,
               axial_load=0.0, axial_factor=None, lubrication="grease"):
    """The friction moment of one bearing row [SKF04] in SI: speed |omega| [rad/s] (> 0), d_m, d, D [m],
    nu [m^2/s], F_r, F_a [N]; ``axial_factor`` Y of a tapered row. Returns a dict of the parts [N m]
    (``M``, ``M_rr`` after the reductions, ``M_rr_full`` before them, ``M_sl``) and the factors
    (``phi_ish``, ``phi_rs``, ``mu_sl``, ``G_rr``, ``G_sl``, ``n_rpm``)."""
    for k, v in (("speed", speed), ("pitch_diameter", pitch_diameter), ("bore", bore), ("outside", outside),
                 ("viscosity", viscosity)):
        check_positive(k, v)
    check_nonnegative("radial_load", radial_load)
    check_nonnegative("axial_load", axial_load)
    n = speed * RPM_PER_RAD_S
    dm, d, D = pitch_diameter * MM_PER_M, bore * MM_PER_M, outside * MM_PER_M
    nu = viscosity * MM2_S_PER_M2_S
    g_rr, g_sl = geometry_variables(c, dm, n, radial_load, axial_load, axial_factor)
    phi_ish = float(inlet_shear_factor(n, dm, nu))
    phi_rs = float(replenishment_factor(n, nu, d, D, c.K_Z, lubrication))
    mu = float(sliding_mu(n, nu, dm, c.mu_ehl))
    m_rr_full = g_rr * (nu * n) ** RR_EXPONENT
    m_rr = phi_ish * phi_rs * m_rr_full
    m_sl = g_sl * mu
    return {"M": (m_rr + m_sl) * NM_PER_NMM, "M_rr": m_rr * NM_PER_NMM, "M_rr_full": m_rr_full * NM_PER_NMM,
            "M_sl": m_sl * NM_PER_NMM, "phi_ish": phi_ish, "phi_rs": phi_rs, "mu_sl": mu, "G_rr": float(g_rr),
            "G_sl": float(g_sl), "n_rpm": float(n)}


# ---------------------------------------------------------------- the rows of a reducer's bearing specs
#: ISO 355 / the 302 series of metric tapered roller bearings (dimension series 2FB): (d, D) [mm] by bore
#: code, as in every maker's product tables (e.g. SKF 30204 J2/Q 20 x 47 x 15.25, 30205 J2/Q 25 x 52 x 16.25).
TAPERED_302_SERIES_MM = {"30203": (17.0, 40.0), "30204": (20.0, 47.0), "30205": (25.0, 52.0),
                         "30206": (30.0, 62.0), "30207": (35.0, 72.0), "30208": (40.0, 80.0),
                         "30209": (45.0, 85.0), "30210": (50.0, 90.0)}
#: The ball rows' ring section, `assumed`: (D - d) = BALL_SECTION_OVER_DW x D_w, range [3, 5] (thin-section
#: angular-contact rings; the main bearing's rings are not in the design files). It enters only phi_rs of
#: the main bearing, which turns at the output speed (phi_rs > 0.85 there at 60 r/min).
BALL_SECTION_OVER_DW = 4.0


def tapered_ring_diameters(pitch_diameter):
    """(d, D) [m] of the 302-series row whose mean diameter (d + D)/2 is the row's pitch diameter within
    0.5 mm; a row of no listed size is refused by name."""
    dm = pitch_diameter * MM_PER_M
    for name, (d, D) in TAPERED_302_SERIES_MM.items():
        if abs(0.5 * (d + D) - dm) <= 0.5:
            return d / MM_PER_M, D / MM_PER_M, name
    raise RvtoolInputError(f"tapered row pitch_diameter = {pitch_diameter} m has no 302-series size in "
                           f"TAPERED_302_SERIES_MM (valid mean diameters: "
                           f"{sorted(0.5 * (d + D) for d, D in TAPERED_302_SERIES_MM.values())} mm)")


def tapered_axial_factor(cup_angle):
    """Y = 0.4 cot(alpha) of a single tapered row (ISO 281:2007, Table 4, F_a/F_r > e), alpha the cup
    (contact) angle [rad]."""
    check_positive("cup_angle", cup_angle)
    return 0.4 / math.tan(cup_angle)
