"""Friction losses of an RV reducer with one cited friction set per contact type (issue 30, Deliver 2):
efficiency over the output speed and the load, the no-load running torque by part, and the catalogue
figures they are compared with.

The friction set (``rvtool/designs/friction_set.toml``, :func:`load_friction_set`) is the same for every
size and speed; each number carries its source there or is `assumed` at the middle of a stated range:

- **rolling bearings**: Palmgren's M = M0 + M1 per mounting (:mod:`rvtool.bearings.friction_torque`),
  the grease column of Harris & Kotzalas' f0 table times the mounting's number of rows, f1 by type,
  the base oil's viscosity at the catalogue's case temperature (ASTM D341, :func:`walther_viscosity`),
  P1 Palmgren's load by bearing type from the mounting's radial resultant and its rows' declared axial
  preload (:mod:`rvtool.bearings.palmgren_load`; the set's ``rolling.palmgren_load = "typed"``, or "radial":
  the radial resultant alone, the form before the correction), omega the relative speed of its rings;
- **involute teeth**: mu per mesh from ISO/TR 14179-2 (:func:`iso_tr_14179_mu`) at the mesh's load (all its
  tooth pairs and slices) per face width, its sum velocity and reduced radius at the pitch point; the loss
  mu F_n |v_t| per row;
- **cycloid--ring-pin contacts**: one mixed-lubrication mu (assumed), the loss mu F_n |v_t| per row;
- **output seal**: P = c d^2 n (radial lip seal, d the seal diameter [mm], n the output speed [r/min]);
- **grease churning**: an assumed fraction of the bearings' load-independent M0 losses.

The accounting is that of :mod:`rvtool.protocols.efficiency` (frictionless static states, kinematic
velocities, first order in the friction coefficients): P_out = |T omega_out|, P_in = P_out + sum of the
losses, eta = P_out / P_in. The no-load running torque at the input is the sum of the losses at zero
output torque over omega_in (:func:`no_load_torque`). Topology: rv2 (pins, gears and the three rolling
sets with rigid cranks); other topologies are refused by name.
"""
import math
import os
import tomllib
from dataclasses import dataclass, replace

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive, check_range
from ..protocols.efficiency import kinematic_velocity, power_balance_error

#: Walther's constant of ASTM D341 [mm^2/s].
WALTHER_SHIFT = 0.7
#: Kelvin of 40 and 100 degC (the ISO viscosity grades' reference temperatures).
T40, T100 = 313.15, 373.15
#: ISO/TR 14179-2 (Schlenk): mu_mz = 0.048 (w / (v rho))^0.2 eta^-0.05 Ra^0.25 X_L in N/mm, m/s, mm, mPa s, um.
ISO_TR_14179_COEFFICIENT = 0.048
#: Radial lip seal friction power P = c d^2 n [W] with d [mm], n [r/min] (friction_set.toml [SEAL]).
MM_PER_M = 1e3
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
ROLLING_ELEMENTS = ("eccentric_bearings", "crank_bearings", "main_bearings")
PARTS = ("pins", "teeth") + ROLLING_ELEMENTS + ("seals", "churning")
#: rolling-bearing friction models of the loss accounting: the friction set's (Palmgren) and SKF's 2004
#: model as the reference of the model-form spread
BEARING_MODELS = ("palmgren", "skf")


@dataclass(frozen=True, kw_only=True)
class FrictionSet:
    """One friction set per contact type (SI). Fields as ``friction_set.toml`` (its comments give each
    source): case_temperature [K]; nu40, nu100: base-oil kinematic viscosity at 40 / 100 degC [m^2/s];
    density [kg/m^3]; f0_* (per row) and f1_* Palmgren's factors [-]; teeth_lubricant_factor X_L [-];
    roughness Ra [m]; pins_mu [-]; seal_coefficient c [W/(mm^2 r/min)]; seal_diameter_ratio (seal
    diameter / main-bearing pitch diameter) [-]; churning_fraction [-]; palmgren_load: the form of
    Palmgren's P1, "typed" (by bearing type with the rows' axial preload) or "radial"
    (:mod:`rvtool.bearings.palmgren_load`)."""
    name: str = "custom"
    case_temperature: float
    nu40: float
    nu100: float
    density: float
    f0_ball: float
    f0_tapered: float
    f0_needle: float
    f1_ball: float
    f1_tapered: float
    f1_needle: float
    teeth_lubricant_factor: float
    roughness: float
    pins_mu: float
    seal_coefficient: float
    seal_diameter_ratio: float
    churning_fraction: float
    palmgren_load: str = "typed"

    def __post_init__(self):
        from ..bearings.palmgren_load import check_mode
        check_mode(self.palmgren_load, "rolling.palmgren_load")
        check_range("friction_set.case_temperature", self.case_temperature, 200.0, 450.0)
        check_positive("lubricant.nu40", self.nu40)
        check_positive("lubricant.nu100", self.nu100)
        if not self.nu100 < self.nu40:
            raise RvtoolInputError(f"lubricant.nu100 = {self.nu100} is outside the valid range (0, nu40 = {self.nu40}) "
                                   "m^2/s: an oil thins with temperature")
        check_positive("lubricant.density", self.density)
        for k in ("f0_ball", "f0_tapered", "f0_needle"):
            check_positive(f"rolling.{k}", getattr(self, k))
        for k in ("f1_ball", "f1_tapered", "f1_needle", "pins_mu", "seal_coefficient", "churning_fraction"):
            check_nonnegative(k, getattr(self, k))
        check_positive("sliding.teeth_lubricant_factor", self.teeth_lubricant_factor)
        check_positive("sliding.roughness", self.roughness)
        check_positive("seals.diameter_over_main_pitch", self.seal_diameter_ratio)

    @property
    def viscosity(self):
        """Base-oil kinematic viscosity at the case temperature [m^2/s] (:func:`walther_viscosity`)."""
        return walther_viscosity(self.nu40, self.nu100, self.case_temperature)


#: friction_set.toml key -> FrictionSet field
_KEYS = {("friction_set", "case_temperature"): "case_temperature", ("lubricant", "nu40"): "nu40",
         ("lubricant", "nu100"): "nu100", ("lubricant", "density"): "density",
         ("rolling", "f0_angular_contact_ball"): "f0_ball", ("rolling", "f0_tapered_roller"): "f0_tapered",
         ("rolling", "f0_needle_roller"): "f0_needle", ("rolling", "f1_angular_contact_ball"): "f1_ball",
         ("rolling", "f1_tapered_roller"): "f1_tapered", ("rolling", "f1_needle_roller"): "f1_needle",
         ("sliding", "teeth_lubricant_factor"): "teeth_lubricant_factor", ("sliding", "roughness"): "roughness",
         ("sliding", "pins_mu"): "pins_mu", ("seals", "friction_coefficient"): "seal_coefficient",
         ("seals", "diameter_over_main_pitch"): "seal_diameter_ratio",
         ("churning", "fraction_of_bearing_M0"): "churning_fraction"}


@dataclass(frozen=True)
class LoadedFrictionSet:
    """A friction set with the ranges of its `assumed` entries: ``ranges[field] = (low, high)`` and the
    file key of each field (``keys[field] = "section.key"``)."""
    central: FrictionSet
    ranges: dict
    keys: dict
    path: str

    def at(self, field, end):
        """The central set with ``field`` at the ``end`` ("low" or "high") of its assumed range."""
        if field not in self.ranges:
            raise RvtoolInputError(f"field = {field!r} is not an assumed entry of {self.path}; valid: {sorted(self.ranges)}")
        if end not in ("low", "high"):
            raise RvtoolInputError(f"end = {end!r}; valid choices are ['low', 'high']")
        return replace(self.central, **{field: self.ranges[field][0 if end == "low" else 1]})


def load_friction_set(path=None):
    """The friction set of ``path`` (default: the shipped ``friction_set.toml``) with its assumed ranges.
    An assumed entry is ``{value, low, high}`` with low <= value <= high; a plain number is cited."""
    from .. import designs
    path = path or designs.path("friction_set")
    with open(path, "rb") as fh:
        table = tomllib.load(fh)
    if "friction_set" not in table:
        raise RvtoolInputError(f"{path}: the [friction_set] table is missing (valid: a friction-set file)")
    values, ranges, keys = {"name": str(table["friction_set"].get("name", "custom"))}, {}, {}
    # the form of Palmgren's P1 (a name, not a number); absent: "typed", Palmgren's definition
    values["palmgren_load"] = table.get("rolling", {}).get("palmgren_load", "typed")
    for (sec, key), field in _KEYS.items():
        where = f"{sec}.{key}"
        if sec not in table or key not in table[sec]:
            raise RvtoolInputError(f"{path}: {where} is missing")
        v = table[sec][key]
        if isinstance(v, dict):
            for k in ("value", "low", "high"):
                if not isinstance(v.get(k), (int, float)) or not math.isfinite(v[k]):
                    raise RvtoolInputError(f"{path}: {where}.{k} = {v.get(k)!r} is not valid (valid: a finite number)")
            if not v["low"] <= v["value"] <= v["high"]:
                raise RvtoolInputError(f"{path}: {where}.value = {v['value']} is outside its range "
                                       f"[{v['low']}, {v['high']}]")
            ranges[field] = (float(v["low"]), float(v["high"]))
            v = v["value"]
        if not isinstance(v, (int, float)) or not math.isfinite(v):
            raise RvtoolInputError(f"{path}: {where} = {v!r} is not valid (valid: a finite number or "
                                   "{value, low, high})")
        values[field] = float(v)
        keys[field] = where
    return LoadedFrictionSet(FrictionSet(**values), ranges, keys, str(path))


def walther_viscosity(nu40, nu100, temperature):
    """Kinematic viscosity [m^2/s] at ``temperature`` [K] through the two points nu40, nu100 [m^2/s] by
    ASTM D341 (Walther): log10 log10(nu + 0.7) = A - B log10 T with nu in mm^2/s."""
    check_positive("nu40", nu40)
    check_positive("nu100", nu100)
    check_positive("temperature", temperature)
    y = [math.log10(math.log10(n * 1e6 + WALTHER_SHIFT)) for n in (nu40, nu100)]
    x = [math.log10(T40), math.log10(T100)]
    B = (y[0] - y[1]) / (x[1] - x[0])
    yt = y[0] - B * (math.log10(temperature) - x[0])
    return (10.0 ** (10.0 ** yt) - WALTHER_SHIFT) * 1e-6


def iso_tr_14179_mu(load_per_width, sum_velocity, reduced_radius, dynamic_viscosity, roughness, lubricant_factor=1.0):
    """Mean tooth friction coefficient of ISO/TR 14179-2 (Schlenk), SI in: load per face width w [N/m],
    sum velocity at the pitch point v [m/s] (> 0), reduced radius of curvature rho [m], dynamic
    viscosity eta [Pa s], roughness Ra [m], X_L [-]. Array ``load_per_width`` broadcasts; w = 0 gives 0."""
    w = np.asarray(load_per_width, float)
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise RvtoolInputError(f"load_per_width must be finite and >= 0 N/m; got {w[~(np.isfinite(w) & (w >= 0))][:4]}")
    for name, v in (("sum_velocity", sum_velocity), ("reduced_radius", reduced_radius),
                    ("dynamic_viscosity", dynamic_viscosity), ("roughness", roughness),
                    ("lubricant_factor", lubricant_factor)):
        check_positive(name, v)
    group = (w * 1e-3) / (sum_velocity * reduced_radius * MM_PER_M)          # (N/mm) / (m/s mm)
    return (ISO_TR_14179_COEFFICIENT * group ** 0.2 * (dynamic_viscosity * 1e3) ** -0.05
            * (roughness * 1e6) ** 0.25 * lubricant_factor)


def _palmgren(f0, f1, dm, nu, omega, load):
    """(M0, M1) [N m] of Palmgren's moment (rvtool.bearings.friction_torque) at |omega| [rad/s], P1 [N]."""
    from ..bearings.friction_torque import PalmgrenFrictionTorque, palmgren_torque
    m0 = float(palmgren_torque(PalmgrenFrictionTorque(f0=f0, f1=0.0, pitch_diameter=dm, kinematic_viscosity=nu),
                               abs(omega), 0.0)[0])
    return m0, f1 * load * dm


def _mounting_factors(bearing, fs):
    """(f0 summed over the rows, f1, d_m [m], rows) of a mounting's bearing."""
    from ..bearings.spec import AngularContactPair, BallBearing, CylindricalRollerBearing
    from ..bearings.tapered import TaperedPair, TaperedRollerBearing
    if isinstance(bearing, CylindricalRollerBearing):
        return fs.f0_needle, fs.f1_needle, bearing.pitch_diameter, 1
    if isinstance(bearing, (BallBearing, AngularContactPair)):
        rows = bearing.rows if isinstance(bearing, AngularContactPair) else (bearing,)
        return fs.f0_ball * len(rows), fs.f1_ball, rows[0].pitch_diameter, len(rows)
    if isinstance(bearing, (TaperedRollerBearing, TaperedPair)):
        rows = bearing.rows if isinstance(bearing, TaperedPair) else (bearing,)
        return fs.f0_tapered * len(rows), fs.f1_tapered, rows[0].pitch_diameter, len(rows)
    raise RvtoolInputError(f"bearing type {type(bearing).__name__} has no entry in the friction set; valid: needle/"
                           "cylindrical roller, ball, angular-contact pair, tapered row or pair")


def _check_bearing_model(bearing_model):
    if bearing_model not in BEARING_MODELS:
        raise RvtoolInputError(f"bearing_model = {bearing_model!r}; valid choices are {list(BEARING_MODELS)}")


def _check_rv2(model, design):
    from ..bearings.set import BearingSet
    from ..bearings.tapered_set import TaperedBearingSet
    if getattr(design, "topology", None) != "rv2":
        raise RvtoolInputError(f"losses: topology = {getattr(design, 'topology', type(design).__name__)!r} is not "
                               "supported (valid: 'rv2')")
    if design.cranks.shaft.elastic or design.cranks.shaft.torsion != "rigid":
        raise RvtoolInputError("losses: cranks.shaft.model / cranks.shaft.torsion are elastic; valid: "
                               "cranks.shaft.model = 'rigid', cranks.shaft.torsion = 'rigid' (the loss accounting "
                               "takes plain rolling-bearing sets)")
    missing = [n for n in ("pins", "gears") + ROLLING_ELEMENTS if n not in model.elements]
    if missing:
        raise RvtoolInputError(f"losses: the model lacks the elements {missing} (valid: topology = 'rv2')")
    for name in ROLLING_ELEMENTS:
        if not isinstance(model.elements[name].evaluator, (BearingSet, TaperedBearingSet)):
            raise RvtoolInputError(f"losses: element {name!r} is not a plain rolling-bearing set; valid: "
                                   "cranks.shaft.model = 'rigid', cranks.shaft.torsion = 'rigid'")


def _element_state(el, q, v):
    return el.pose_velocity(el.local(q), el.local(v))


def _rows(el, q, v):
    """(F_n [N], |v_t| [m/s]) per contact row at the static state q moving at v."""
    pose, vel = _element_state(el, q, v)
    fn = np.maximum(el.evaluator.evaluate(pose, 0 * vel, check=False).obs[:, 0], 0.0)
    vt = np.abs(el.evaluator.evaluate(pose, vel, check=False).obs[:, 1])
    return fn, vt


def sun_mesh_geometry(design):
    """(working pitch radius of the sun r_w1 [m], working pressure angle alpha_w [rad], reduced radius at
    the pitch point rho_C [m], face width b [m]) of the sun--crank-gear pair."""
    from ..geometry.involute import InvolutePair
    pair = InvolutePair(gear_a=design.sun_gear, gear_b=design.crank_gear)
    rw1, rw2 = pair.working_pitch_radii
    aw = pair.working_pressure_angle
    r1, r2 = rw1 * math.sin(aw), rw2 * math.sin(aw)
    return rw1, aw, r1 * r2 / (r1 + r2), min(design.sun_gear.face_width, design.crank_gear.face_width)


def _skf_rows(bearing, fs, omega, load, constants=None):
    """[(row label, SkfConstants key, skf_moment dict)] of one mounting's rows at |omega| [rad/s] and the
    mounting's radial resultant ``load`` [N] (rvtool.bearings.skf_friction; the loads per row below).
    ``constants``: {key: SkfConstants} replacing entries of ``skf_friction.CONSTANTS`` (a sensitivity)."""
    from ..bearings import skf_friction as S
    C = {**S.CONSTANTS, **(constants or {})}
    from ..bearings.palmgren_load import row_loads
    from ..bearings.spec import AngularContactPair, CylindricalRollerBearing
    from ..bearings.tapered import TaperedPair
    nu = fs.viscosity
    if isinstance(bearing, CylindricalRollerBearing):
        # a caged roller set on its raceways (the RV's eccentric needles: journal and wheel bore, no rings):
        # d, D the raceway diameters; one row carries the mounting's radial resultant
        d = 2.0 * bearing.inner_radius
        D = d + 2.0 * bearing.roller_diameter
        c = C["needle_roller"]
        return [("row", "needle_roller", S.skf_moment(c, speed=omega, pitch_diameter=0.5 * (d + D), bore=d, outside=D,
                                                      viscosity=nu, radial_load=load))]
    if isinstance(bearing, TaperedPair):
        # the rows' F_r and F_a as Palmgren's P1 takes them (rvtool.bearings.palmgren_load.row_loads: half the
        # pair's radial resultant each, F_a the larger of the preload and the induced 0.5 F_r / Y)
        out = []
        for k, (row, (_, fr, fa, _)) in enumerate(zip(bearing.rows, row_loads(bearing, load))):
            d, D, size = S.tapered_ring_diameters(row.pitch_diameter)
            out.append((f"row{k} ({size})", "tapered_roller_302",
                        S.skf_moment(C["tapered_roller_302"], speed=omega, pitch_diameter=row.pitch_diameter,
                                     bore=d, outside=D, viscosity=nu, radial_load=fr, axial_load=fa,
                                     axial_factor=S.tapered_axial_factor(row.cup_angle))))
        return out
    if isinstance(bearing, AngularContactPair):
        # the rows' F_r and F_a as Palmgren's P1 takes them (row_loads: half the radial resultant each, the
        # row's own axial preload)
        out = []
        for k, (row, (_, fr, fa, _)) in enumerate(zip(bearing.rows, row_loads(bearing, load))):
            h = 0.5 * S.BALL_SECTION_OVER_DW * row.ball_diameter
            out.append((f"row{k}", "angular_contact_72B",
                        S.skf_moment(C["angular_contact_72B"], speed=omega, pitch_diameter=row.pitch_diameter,
                                     bore=row.pitch_diameter - h, outside=row.pitch_diameter + h, viscosity=nu,
                                     radial_load=fr, axial_load=fa)))
        return out
    raise RvtoolInputError(f"bearing type {type(bearing).__name__} has no SKF reference rows; valid: needle/cylindrical "
                           "roller set, tapered pair, angular-contact pair")


def rolling_audit(model, design, fs: FrictionSet, q, v, *, skf=True, skf_constants=None):
    """One row per bearing mounting at the static state q moving at v: the element and mounting, the
    bearing type and rows, d_m [m], the rings' relative speed [rad/s and r/min], P1 [N] (the friction set's
    form ``palmgren_load``; with the radial resultant ``P1_radial_N`` and the typed P1 per row), Palmgren's f0
    (summed over the rows), f1, M0, M1 [N m] and loss [W] (the friction set's accounting), and with
    ``skf`` the SKF 2004 reference (rvtool.bearings.skf_friction) per row and in total [W];
    ``skf_constants`` replaces entries of its constants (:func:`_skf_rows`)."""
    from ..bearings.friction_element import ElementResultantLoads
    from ..bearings.palmgren_load import palmgren_load, row_loads
    nu = fs.viscosity
    rows = []
    for name in ROLLING_ELEMENTS:
        bset = model.elements[name].evaluator
        pose, vel = _element_state(model.elements[name], q, v)
        radial = ElementResultantLoads(bset, [m.name for m in bset.mountings])(pose, vel)
        for m, fr in zip(bset.mountings, radial):
            p = palmgren_load(m.bearing, fr, fs.palmgren_load)
            f0, f1, dm, n_rows = _mounting_factors(m.bearing, fs)
            wa = vel[m.inner, 2] if m.inner >= 0 else 0.0
            wb = vel[m.outer, 2] if m.outer >= 0 else 0.0
            w = abs(wa - wb)
            m0, m1 = _palmgren(f0, f1, dm, nu, w, p)
            w = float(w)
            row = {"element": name, "mounting": m.name, "bearing_type": type(m.bearing).__name__, "rows": n_rows,
                   "pitch_diameter_m": dm, "omega_rel_rad_s": w, "n_rel_rpm": w * RPM_PER_RAD_S, "P1_N": float(p),
                   "P1_radial_N": float(fr), "palmgren_load": fs.palmgren_load,
                   "P1_rows": [{"row": lab, "F_r_N": a, "F_a_N": b, "P1_N": c}
                               for lab, a, b, c in row_loads(m.bearing, fr)],
                   "palmgren_f0": f0, "palmgren_f1": f1, "viscosity_m2_s": nu, "palmgren_M0_Nm": m0,
                   "palmgren_M1_Nm": m1, "palmgren_loss_W": (m0 + m1) * w}
            if skf:
                # SKF's model takes each row's radial and axial load itself (_skf_rows): the radial resultant
                parts = _skf_rows(m.bearing, fs, w, float(fr), skf_constants) if w > 0 else []
                row["skf_rows"] = [{"row": lab, "constants": key, **r} for lab, key, r in parts]
                row["skf_M_Nm"] = float(sum(r["M"] for _, _, r in parts))
                row["skf_loss_W"] = row["skf_M_Nm"] * w
            rows.append(row)
    return rows


def closed_form_relative_speeds(design, output_speed_rpm):
    """The rings' relative speeds [r/min] of the rv2 rolling sets from the gear numbers alone (ring pins
    fixed, the carrier the output at n_out): input n_in = n_out (1 + (z_crank/z_sun) Z_p); each crank
    turns in the carrier at n_c = (z_sun/z_crank)(n_in - n_out) = Z_p n_out; the eccentric turns in the
    fixed frame at n_e = n_out - n_c and the wheel (Z_p - 1 lobes on Z_p pins) at n_w = -n_e / (Z_p - 1)
    = n_out, so the needles turn at |n_e - n_w| = Z_p n_out; the main bearing at n_out."""
    zs, zc, zp = design.sun_gear.n_teeth, design.crank_gear.n_teeth, design.pins.n_pins
    n_out = float(output_speed_rpm)
    n_in = n_out * (1.0 + zc / zs * zp)
    n_c = zs / zc * (n_in - n_out)
    n_e = n_out - n_c
    n_w = -n_e / (zp - 1)
    return {"input_rpm": n_in, "eccentric_bearings": abs(n_e - n_w), "crank_bearings": abs(n_c),
            "main_bearings": abs(n_out), "wheel_rpm": n_w}


def part_losses(model, design, fs: FrictionSet, q, v, *, bearing_model="palmgren"):
    """{part: loss [W]} at the static state q moving at the kinematic velocities v (module docstring),
    with ``m0_W`` (the rolling sets' load-independent Palmgren M0 losses) and ``teeth_mu`` (the ISO/TR
    14179-2 coefficient) as extra keys. ``bearing_model``: "palmgren" (the friction set's) or "skf" (the
    reference model :mod:`rvtool.bearings.skf_friction` on the rolling sets only; every other part, the
    churning share of the Palmgren M0 included, unchanged: the model-form spread of the bearings)."""
    _check_bearing_model(bearing_model)
    nu = fs.viscosity
    out = {}
    fn, vt = _rows(model.elements["pins"], q, v)
    out["pins"] = float(fs.pins_mu * np.sum(fn * vt))
    # teeth: ISO/TR 14179-2 per row at the row's load per width (F_n over the slice's width)
    rw1, aw, rho, b = sun_mesh_geometry(design)
    w_rel = abs(v[model.input_index] - v[model.output_index])
    v_sum = 2.0 * w_rel * rw1 * math.sin(aw)
    gears = model.elements["gears"]
    fn, vt = _rows(gears, q, v)
    # ISO/TR 14179-2's load is the mesh's transverse load over its face width (every tooth pair and slice of
    # the mesh together), one mu per mesh for its rows
    mesh_of = np.asarray(gears.evaluator.mesh_of)
    mesh_load = np.bincount(mesh_of, weights=fn)
    mu_mesh = iso_tr_14179_mu(mesh_load / b, v_sum, rho, nu * fs.density, fs.roughness, fs.teeth_lubricant_factor)
    mu = mu_mesh[mesh_of]
    out["teeth"] = float(np.sum(mu * fn * vt))
    loaded = fn > 0
    out["teeth_mu"] = float(np.sum(mu[loaded] * fn[loaded]) / np.sum(fn[loaded])) if loaded.any() else 0.0
    m0_total, main_dm = 0.0, None
    for name in ROLLING_ELEMENTS:
        out[name] = 0.0
    for row in rolling_audit(model, design, fs, q, v, skf=bearing_model == "skf"):
        name = row["element"]
        out[name] = out.get(name, 0.0) + (row["skf_loss_W"] if bearing_model == "skf" else row["palmgren_loss_W"])
        m0_total += row["palmgren_M0_Nm"] * row["omega_rel_rad_s"]
        if name == "main_bearings":
            main_dm = row["pitch_diameter_m"]
    n_out = abs(v[model.output_index]) * RPM_PER_RAD_S
    d_seal = fs.seal_diameter_ratio * main_dm * MM_PER_M
    out["seals"] = fs.seal_coefficient * d_seal ** 2 * n_out
    out["churning"] = fs.churning_fraction * m0_total
    out["m0_W"] = m0_total
    return out


def _states(model, torque, input_angles):
    from ..solver.static import StaticSolver
    model.set_output_torque(-np.sign(model.ratio) * abs(torque))
    solver = StaticSolver(model)
    out, prev = [], None
    for a in input_angles:
        q = solver.solve(float(a), previous_angle=prev)
        prev = float(a)
        out.append((float(a), q.copy()))
    return out


def _average(model, design, fs, states, w_in, bearing_model="palmgren"):
    acc, p_out, imbalance = {}, 0.0, 0.0
    for a, q in states:
        v = kinematic_velocity(model, a, w_in)
        for k, val in part_losses(model, design, fs, q, v, bearing_model=bearing_model).items():
            acc[k] = acc.get(k, 0.0) + val / len(states)
        if np.any(q):
            _, P_in, P_out = power_balance_error(model, q, v)
            p_out += abs(P_out) / len(states)
            imbalance += (abs(P_in) - abs(P_out)) / len(states)
    return acc, p_out, imbalance


def efficiency_map(model, design, fs: FrictionSet, *, torque_ratios=(1.0,), output_speeds_rpm=(15.0,),
                   input_angles=(0.0,), bearing_model="palmgren"):
    """Efficiency at output torques ``torque_ratios`` x T_R and output speeds [r/min], averaged over
    ``input_angles`` [rad] (static states solved once per torque and angle). One row per (ratio, speed):
    efficiency, P_out, P_loss [W], loss_by_part [W], teeth_mu, the frictionless power balance.
    ``bearing_model``: :data:`BEARING_MODELS` (:func:`part_losses`)."""
    _check_rv2(model, design)
    _check_bearing_model(bearing_model)
    ratio = abs(float(model.ratio))
    for r in torque_ratios:
        check_range("torque_ratio", r, 0.0, 10.0, low_open=True)
    for s in output_speeds_rpm:
        check_positive("output_speed_rpm", s)
    rows = []
    for r in torque_ratios:
        states = _states(model, r * design.rated_torque, input_angles)
        for n_out in output_speeds_rpm:
            w_in = n_out * ratio * 2.0 * math.pi / 60.0
            acc, p_out, imbalance = _average(model, design, fs, states, w_in, bearing_model)
            parts = {k: acc[k] for k in PARTS}
            loss = sum(parts.values())
            rows.append({"torque_ratio": float(r), "output_torque_Nm": float(r * design.rated_torque),
                         "output_speed_rpm": float(n_out), "input_speed_rpm": float(n_out * ratio),
                         "efficiency": p_out / (p_out + loss), "P_out_W": p_out, "P_loss_W": loss,
                         "loss_by_part_W": parts, "rolling_M0_W": acc["m0_W"], "teeth_mu": acc["teeth_mu"],
                         "frictionless_power_balance_rel_err": abs(imbalance) / p_out})
    return {"friction_set": fs.name, "viscosity_at_case_temperature_m2_s": fs.viscosity,
            "input_angles_rad": [float(a) for a in input_angles], "points": rows}


def no_load_torque(model, design, fs: FrictionSet, input_speed_rpm, *, input_angles=(0.0,), bearing_model="palmgren"):
    """Input-side running torque [N m] at zero output torque and ``input_speed_rpm``, by part: each
    part's loss over omega_in (the bearings' M0 and their M1 at the unloaded state, seals, churning;
    the sliding contacts carry no load). Returns {"by_part_Nm": {...}, "total_Nm": ...}."""
    _check_rv2(model, design)
    _check_bearing_model(bearing_model)
    check_positive("input_speed_rpm", input_speed_rpm)
    states = _states(model, 0.0, input_angles)
    w_in = input_speed_rpm * 2.0 * math.pi / 60.0
    acc, _, _ = _average(model, design, fs, states, w_in, bearing_model)
    by_part = {k: acc[k] / w_in for k in PARTS}
    return {"input_speed_rpm": float(input_speed_rpm), "by_part_Nm": by_part, "total_Nm": sum(by_part.values()),
            "rolling_M0_Nm": acc["m0_W"] / w_in}


# ---------------------------------------------------------------- the catalogue's efficiency figures
@dataclass(frozen=True)
class EfficiencyCurve:
    """The catalogue's efficiency at T_R over the output speed (fractions, speeds in r/min)."""
    design: str
    output_speed_rpm: tuple
    efficiency: tuple
    low: tuple
    high: tuple
    kind: str
    status: str


@dataclass(frozen=True)
class NoLoadFigure:
    design: str
    input_speed_rpm: float
    torque: float
    low: float
    high: float
    kind: str
    status: str


@dataclass(frozen=True)
class EfficiencyCatalogue:
    """``rv_e_efficiency.toml``: curves per design, the correction coefficient K(alpha) and the no-load
    running torques, with the source, the case temperature [K] and the reading status."""
    title: str
    edition: str
    case_temperature: float
    conditions: str
    status: str
    curves: dict
    correction_ratio: tuple
    correction: tuple
    correction_band: float
    correction_status: str
    no_load: dict
    path: str

    def citation(self):
        return f"{self.title}, {self.edition} (status {self.status})"


def _seq(t, key, where, n=None):
    v = t.get(key)
    if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in v):
        raise RvtoolInputError(f"{where}.{key} = {v!r} is not valid (valid: a non-empty list of finite numbers)")
    if n is not None and len(v) != n:
        raise RvtoolInputError(f"{where}.{key} has {len(v)} entries (valid: {n}, as output_speed_rpm)")
    return tuple(float(x) for x in v)


def load_efficiency_catalogue(path=None):
    """The series' efficiency figures (default: the shipped ``rv_e_efficiency.toml``)."""
    from .. import designs
    path = path or designs.path("rv_e_efficiency")
    with open(path, "rb") as fh:
        t = tomllib.load(fh)
    if "efficiency_catalogue" not in t:
        raise RvtoolInputError(f"{path}: the [efficiency_catalogue] table is missing")
    h = t["efficiency_catalogue"]
    curves = {}
    for i, c in enumerate(t.get("efficiency_curve", [])):
        where = f"efficiency_curve[{i}]"
        n = _seq(c, "output_speed_rpm", where)
        vals = [tuple(x / 100.0 for x in _seq(c, k, where, len(n))) for k in ("efficiency_pct", "low_pct", "high_pct")]
        for j, (lo, v, hi) in enumerate(zip(vals[1], vals[0], vals[2])):
            if not (0.0 < lo <= v <= hi <= 1.0):
                raise RvtoolInputError(f"{where}: point {j} needs 0 < low_pct <= efficiency_pct <= high_pct <= 100")
        curves[c["design"]] = EfficiencyCurve(c["design"], n, *vals, c.get("kind", "typical"), c.get("status", "not_reread"))
    corr = t.get("correction", {})
    ratio = _seq(corr, "torque_ratio", "correction")
    coef = _seq(corr, "coefficient", "correction", len(ratio))
    no_load = {}
    for i, f in enumerate(t.get("no_load_torque", [])):
        where = f"no_load_torque[{i}]"
        for k in ("input_speed_rpm", "torque_Nm", "low_Nm", "high_Nm"):
            check_positive(f"{where}.{k}", f.get(k, float("nan")))
        no_load[f["design"]] = NoLoadFigure(f["design"], float(f["input_speed_rpm"]), float(f["torque_Nm"]),
                                            float(f["low_Nm"]), float(f["high_Nm"]), f.get("kind", "typical"),
                                            f.get("status", "not_reread"))
    return EfficiencyCatalogue(h.get("title", ""), h.get("edition", ""), float(h["case_temperature_C"]) + 273.15,
                               h.get("conditions", ""), h.get("status", "not_reread"), curves, ratio, coef,
                               float(corr.get("band", 0.0)), corr.get("status", "not_reread"), no_load, str(path))


def catalogue_efficiency(curve: EfficiencyCurve, output_speed_rpm):
    """The catalogue's efficiency at T_R [fraction] at ``output_speed_rpm``, linear between its points;
    outside the chart's range a clear error (no extrapolation)."""
    n = curve.output_speed_rpm
    check_range("output_speed_rpm", output_speed_rpm, n[0], n[-1])
    return float(np.interp(output_speed_rpm, n, curve.efficiency))


# ---------------------------------------------------------------- the hysteresis loss split
def hysteresis_split(design, *, pins_mu, teeth_mu, step=0.125, fine_levels=(0.0005, 0.001, 0.003, 0.01, 0.03)):
    """The catalogue's hysteresis loss [arcmin] split into its clearance and friction shares: two repeating
    quasi-static cycles over +-T_R (rvtool.protocols.hysteresis_cycles, the catalogue's definition of
    rvtool.protocols.catalogue) with friction off and on (anchor friction ``pins_mu`` on the cycloid--pin
    mesh, ``teeth_mu`` on the involute stage, the anchors' stiffness at the rated mesh force).

    - clearance share: the loss with friction off (the free play, crossed at zero torque; its loop
      encloses no area up to the quadrature);
    - friction share by the catalogue's definition: loss(on) - loss(off);
    - friction share by energy: the area of the loop with friction on over its height, A / (2 T_R) (a
      loop of constant width w between -T_R and +T_R encloses 2 T_R w; the frictionless loop's area is
      the quadrature's residue), with the dissipation per family.
    """
    from ..assembly.rv.gear_graph import GearGraph
    from ..protocols import hysteresis_cycles as HC
    from ..units import RAD_PER_ARCMIN
    from ..assembly import build
    check_nonnegative("pins_mu", pins_mu)
    check_nonnegative("teeth_mu", teeth_mu)
    g = GearGraph.of(design)
    f_mesh = design.rated_torque / abs(g.ratio) / g.sun_pair.gear_a.base_radius / design.cranks.count
    seq = HC.CycleSequence(rated_torque=design.rated_torque, step=step, fine_levels=fine_levels)
    out = {}
    for key, (mp, mt) in (("off", (0.0, 0.0)), ("on", (pins_mu, teeth_mu))):
        d = design.replace(pin_contact={"mu": mp, "friction_model": "anchor"},
                           involute_stage={"mu": mt, "friction_model": "anchor", "reference_force": f_mesh})
        r = HC.quasi_static_cycles(build(d), seq)
        last = r["cycles"][-1]
        fig = HC.catalogue_figures(last["torque_Nm"], last["angle_rad"], last["labels"], design.rated_torque)
        out[key] = {"hysteresis_loss_arcmin": fig.hysteresis_loss_arcmin, "loop_J": fig.loop_integral_J,
                    "dissipation_J": {k: float(v) for k, v in last["friction_dissipation_J"].items()}}
    width = lambda a: a / (2.0 * design.rated_torque) / RAD_PER_ARCMIN   # noqa: E731
    off, on = out["off"], out["on"]
    return {"pins_mu": pins_mu, "teeth_mu": teeth_mu, "step": step,
            "hysteresis_loss_off_arcmin": off["hysteresis_loss_arcmin"],
            "hysteresis_loss_on_arcmin": on["hysteresis_loss_arcmin"],
            "clearance_share_arcmin": off["hysteresis_loss_arcmin"],
            "friction_share_catalogue_arcmin": on["hysteresis_loss_arcmin"] - off["hysteresis_loss_arcmin"],
            "friction_share_energy_arcmin": width(on["loop_J"] - off["loop_J"]),
            "loop_off_J": off["loop_J"], "loop_on_J": on["loop_J"], "dissipation_on_J": on["dissipation_J"]}


# ---------------------------------------------------------------- `rvtool validate`'s efficiency rows
#: Input angles over one mesh period of validate's efficiency rows (quick, full): the power balance's
#: mean converges with them (rv40e 4.4e-5 at 8); the losses move by < 0.1 point between 4 and 8.
VALIDATE_ANGLES = (4, 8)

CHART_SPEEDS_RPM = ((5.0, 15.0, 30.0, 60.0), (5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0, 60.0))
"""Output speeds [rpm] of the efficiency cases' chart (quick, full): the catalogue chart's span, 5-60 rpm."""

CHART_ANGLES = (8, 16)
"""Input angles per mesh period the efficiency cases average over (quick, full)."""


def chart_inputs(quick):
    """(friction set, efficiency catalogue, output speeds [rpm], input angles per mesh period) of the efficiency
    cases (cases/rv/efficiency_rv.py, efficiency_audit.py): the shipped files, the chart's grid of
    :data:`CHART_SPEEDS_RPM` and :data:`CHART_ANGLES` (quick or full)."""
    k = 0 if quick else 1
    return load_friction_set(), load_efficiency_catalogue(), CHART_SPEEDS_RPM[k], CHART_ANGLES[k]


def mesh_angles(model, n):
    """``n`` input angles [rad] evenly over one mesh period of ``model`` (the averaging of the loss accounting)."""
    return tuple(float(a) for a in np.arange(n) * model.mesh_period / n)


def loss_design(design):
    """(design, note): the design the loss accounting runs on. A design with elastic crank bending or
    torsion or the ported housing runs as its rigid-member variant (the accounting takes plain
    rolling-bearing sets; the elastic members change the load sharing, second order in the losses)."""
    d, note = design, "as shipped"
    if d.cranks.shaft.elastic or d.cranks.shaft.torsion != "rigid" or getattr(d.housing, "model", "rigid") != "rigid":
        d = d.replace(cranks={"shaft": {"model": "rigid", "tilt": False, "torsion": "rigid"}}, housing={"model": "rigid"})
        note = ("run with cranks.shaft.model = 'rigid' (tilt off, torsion rigid) and housing.model = 'rigid' "
                "(shipped: elastic members on); the loss accounting takes plain rolling-bearing sets")
    return d, note


def validate_efficiency(name, design, *, quick=False):
    """Rows of `rvtool validate`'s table for the efficiency at T_R at every speed of the catalogue's chart and
    the no-load running torque (the shipped friction set, central values), with the curve for the plot:
    {"rows": [...], "curve": {...}, "no_load": {...}, "note": ...}. A design without efficiency figures gives
    no rows and says so."""
    cat = load_efficiency_catalogue()
    if name not in cat.curves:
        return {"rows": [], "note": f"no efficiency figures for {name!r} in {cat.path}"}
    fs = load_friction_set().central
    d, note = loss_design(design)
    from ..assembly import build
    model = build(d)
    angles = mesh_angles(model, VALIDATE_ANGLES[0 if quick else 1])
    curve, fig = cat.curves[name], cat.no_load.get(name)
    r = efficiency_map(model, d, fs, output_speeds_rpm=curve.output_speed_rpm, input_angles=angles)
    base = {"unit": "%", "band": None, "catalogue_unit": "%", "kind": curve.kind, "status": curve.status,
            "source": f"{cat.citation()}, efficiency chart ({os.path.basename(cat.path)})",
            "note": f"friction set {fs.name} (rvtool/designs/friction_set.toml); {note}"}
    rows = []
    for p, c, lo, hi in zip(r["points"], curve.efficiency, curve.low, curve.high):
        diff = 100 * (p["efficiency"] - c)
        rows.append({**base, "figure": f"efficiency_{p['output_speed_rpm']:g}rpm", "predicted": 100 * p["efficiency"],
                     "catalogue": 100 * c, "catalogue_range": [100 * lo, 100 * hi],
                     "conditions": f"T_R, output {p['output_speed_rpm']:g} rpm, case {cat.case_temperature - 273.15:g} "
                                   "degC, grease",
                     "verdict": f"{diff:+.1f} points ({'within' if abs(diff) <= 5 else 'outside'} the 5-point target)"
                                + (" (catalogue value not re-read from the page)" if curve.status == "not_reread"
                                   else "")})
    out = {"rows": rows, "note": note, "curve": {"output_speed_rpm": list(curve.output_speed_rpm),
                                                 "model": [p["efficiency"] for p in r["points"]],
                                                 "catalogue": list(curve.efficiency), "low": list(curve.low),
                                                 "high": list(curve.high), "status": curve.status},
           "loss_by_part_W": [p["loss_by_part_W"] for p in r["points"]]}
    if fig is not None:
        nl = no_load_torque(model, d, fs, fig.input_speed_rpm, input_angles=angles)
        ratio = nl["total_Nm"] / fig.torque
        rows.append({**base, "figure": "no_load_running_torque", "predicted": nl["total_Nm"], "unit": "N m",
                     "catalogue": fig.torque, "catalogue_unit": "N m", "catalogue_range": [fig.low, fig.high],
                     "kind": fig.kind, "status": fig.status,
                     "source": f"{cat.citation()}, no-load running torque ({os.path.basename(cat.path)})",
                     "conditions": f"input side, {fig.input_speed_rpm:g} rpm input, zero output torque, case "
                                   f"{cat.case_temperature - 273.15:g} degC",
                     "ratio": ratio,
                     "verdict": f"x{ratio:.2f} ({'within' if 0.5 <= ratio <= 2 else 'outside'} the factor-2 target)"
                                + (" (catalogue value not re-read from the page)" if fig.status == "not_reread"
                                   else ""),
                     "note": "by part [N m]: " + ", ".join(f"{k} {v:.3g}" for k, v in nl["by_part_Nm"].items())})
        out["no_load"] = nl
    return out


def efficiency_plot(validation, out_dir):
    """efficiency.png of a `rvtool validate` results dict (its ``efficiency`` entry); returns the file names
    written ([] without a curve)."""
    c = (validation.get("efficiency") or {}).get("curve")
    if not c:
        return []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = c["output_speed_rpm"]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(n, [100 * e for e in c["model"]], "o-", label="model (friction set, central)")
    ax.errorbar(n, [100 * e for e in c["catalogue"]],
                yerr=[[100 * (e - lo) for e, lo in zip(c["catalogue"], c["low"])],
                      [100 * (hi - e) for e, hi in zip(c["catalogue"], c["high"])]],
                fmt="s--", mfc="none", capsize=3, label=f"catalogue ({c['status']})")
    ax.set(xlabel="output speed [r/min]", ylabel="efficiency at T_R [%]",
           title=f"{validation['design']}: efficiency, case 30 degC")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "efficiency.png"), dpi=110)
    plt.close(fig)
    return ["efficiency.png"]
