"""Tolerance-file templates (``rvtool new`` writes ``NAME_tolerances.toml`` beside ``NAME.toml``): the
manufacturing tolerances of a design of one's own for the tolerance Monte Carlo of ``rvtool analyze``.

The keys and their TOML form are those of the topology's tolerance loader (cycloid:
:mod:`rvtool.variants.tolerances`; RV two- and three-stage: :mod:`rvtool.variants.rv_tolerances`;
small-tooth-difference involute: :mod:`rvtool.variants.std_tolerances`). Every key's comment starts with
``source:`` (a grade read off a standard at the design's own sizes) or ``assumed:`` (a chosen value, with
the range it was chosen from). "std" of a normal is one third of the +- tolerance (3-sigma process
capability), as in the shipped tolerance files.

Size-dependent grades are computed from the design at writing time:

* ISO 286-1:2010, Table 1, standard tolerance grade IT4 (:data:`ISO286_IT4_UM`) for the ground ring pins
  (h4: upper deviation 0, lower deviation -IT4 on the diameter, ISO 286-2),
* ISO 286-1:2010, Table 1, IT5 (:data:`ISO286_IT5_UM`) of the pin circle diameter as the coaxiality tolerance
  of a cycloid drive's pin circle to the output axis (the [POS] rule of rv80e_tolerances.toml),
* ISO 1328-1:2013, eq. (5), the single pitch tolerance f_pT = (0.001 d + 0.4 m_n + 5) sqrt(2)^(A - 5) um
  (d, m_n in mm; A the flank tolerance class), rounded by the standard's 5.2.3 rule (below 5 um to 0.1 um,
  5 to 10 um to 0.5 um, above 10 um to 1 um), within its scope 5 <= d <= 15000 mm, 0.5 <= m_n <= 70 mm,
* ISO 1328-1:2013 clause 5.3.3, the profile slope tolerance f_HaT = (0.4 m_n + 0.001 d + 4) sqrt(2)^(A - 5) um
  (:func:`iso1328_profile_slope`), and the runout tolerance F_rT = 0.9 F_pT with the cumulative pitch tolerance
  F_pT = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12) sqrt(2)^(A - 5) um (:func:`iso1328_runout`), both rounded as
  f_pT; these two formulas are RECALLED, NOT RE-READ from the printed standard (as the [ISO1328P] and
  [ISO1328R] notes of rv80e_tolerances.toml): the profile slope is taken as the analogue tolerance of the
  ground cycloid profile, the runout as the eccentricity of a gear's pitch circle.

The RV template writes every field of :data:`rvtool.designs.tolerance_keys.RV_TOLERANCE_KEYS` in the loader's
order by the rules of rv80e_tolerances.toml ([ISO1328], [ISO286], [ISO1101], [POS], [ISO1328P], [ISO1328R]),
at the design's own sizes: the pin ring as a gear of module 2 l_R / z_b (z_b pins) and its pin circle diameter,
the cycloid wheel as a gear of that module and z_g = z_b - 1 teeth, the crank circle of diameter 2 a (a the
sun--crank-gear centre distance), the sun and crank gears' own d and m_n.

A design whose pin diameter or gears change should have its tolerance file written anew
(``rvtool new --tolerances-for NAME.toml``: :func:`tolerance_template` of the changed design).
"""
import math

from ..errors import RvtoolInputError

ISO286_IT4_UM = ((3.0, 3.0), (6.0, 4.0), (10.0, 4.0), (18.0, 5.0), (30.0, 6.0), (50.0, 7.0), (80.0, 8.0),
                 (120.0, 10.0), (180.0, 12.0), (250.0, 14.0), (315.0, 16.0), (400.0, 18.0), (500.0, 20.0))
"""ISO 286-1:2010, Table 1: standard tolerance IT4 [um] of nominal sizes above the previous row's bound up
to and including this row's [mm] (the first row: up to 3 mm)."""

ISO286_IT5_UM = ((3.0, 4.0), (6.0, 5.0), (10.0, 6.0), (18.0, 8.0), (30.0, 9.0), (50.0, 11.0), (80.0, 13.0),
                 (120.0, 15.0), (180.0, 18.0), (250.0, 20.0), (315.0, 23.0), (400.0, 25.0), (500.0, 27.0))
"""ISO 286-1:2010, Table 1: standard tolerance IT5 [um], rows as :data:`ISO286_IT4_UM`."""

FLANK_CLASS = 5
"""ISO 1328-1:2013 flank tolerance class of the template's gears (chosen: ground gears of a precision
reducer; the shipped rv40e_tolerances.toml takes grade 5 too)."""


def iso286_it4(size, key):
    """IT4 [m] of nominal size ``size`` [m] (ISO 286-1:2010 Table 1); ``key`` names the design key."""
    return _iso286(size, key, ISO286_IT4_UM)


def iso286_it5(size, key):
    """IT5 [m] of nominal size ``size`` [m] (ISO 286-1:2010 Table 1); ``key`` names the design key."""
    return _iso286(size, key, ISO286_IT5_UM)


def _iso286(size, key, table):
    mm = size * 1e3
    for upper, it in table:
        if 0.0 < mm <= upper:
            return it * 1e-6
    raise RvtoolInputError(f"{key}: nominal size {mm:.6g} mm is outside the ISO 286-1 table of this template "
                           f"(0, 500] mm; write the tolerance file by hand")


def iso1328_single_pitch(d, m, key, flank_class=FLANK_CLASS):
    """Single pitch tolerance f_pT [m] (ISO 1328-1:2013 eq. (5), rounded by 5.2.3) of a gear of reference
    diameter ``d`` [m] and normal module ``m`` [m]; ``key`` names the gear's design section."""
    d_mm, m_mm = d * 1e3, m * 1e3
    _iso1328_scope(d_mm, m_mm, key)
    return _iso1328_round((0.001 * d_mm + 0.4 * m_mm + 5.0) * math.sqrt(2.0) ** (flank_class - 5))


def _iso1328_scope(d_mm, m_mm, key):
    if not 5.0 <= d_mm <= 15000.0 or not 0.5 <= m_mm <= 70.0:
        raise RvtoolInputError(f"{key}: d = {d_mm:.6g} mm, m = {m_mm:.6g} mm is outside the scope of ISO 1328-1:2013 "
                               f"(5 <= d <= 15000 mm, 0.5 <= m_n <= 70 mm); write the tolerance file by hand")


def _iso1328_round(v):
    """ISO 1328-1:2013 5.2.3: below 5 um to 0.1 um, 5 to 10 um to 0.5 um, above 10 um to 1 um; ``v`` [um] -> [m]."""
    step = 1.0 if v > 10.0 else 0.5 if v >= 5.0 else 0.1
    return math.floor(v / step + 0.5) * step * 1e-6


def iso1328_profile_slope(d, m, key, flank_class=FLANK_CLASS):
    """Profile slope tolerance f_HaT [m] = (0.4 m_n + 0.001 d + 4) sqrt(2)^(A - 5) um (ISO 1328-1:2013 clause
    5.3.3; formula RECALLED, NOT RE-READ from the printed standard, as [ISO1328P] of rv80e_tolerances.toml),
    rounded by 5.2.3, of a gear of reference diameter ``d`` [m] and normal module ``m`` [m]."""
    d_mm, m_mm = d * 1e3, m * 1e3
    _iso1328_scope(d_mm, m_mm, key)
    return _iso1328_round((0.4 * m_mm + 0.001 * d_mm + 4.0) * math.sqrt(2.0) ** (flank_class - 5))


def iso1328_cumulative_pitch_um(d, m, flank_class=FLANK_CLASS):
    """Cumulative pitch tolerance F_pT [um, unrounded] = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12) sqrt(2)^(A - 5)
    (ISO 1328-1:2013 clause 5.3; RECALLED, NOT RE-READ, as [ISO1328R] of rv80e_tolerances.toml); d, m [m]."""
    d_mm, m_mm = d * 1e3, m * 1e3
    return (0.002 * d_mm + 0.55 * math.sqrt(d_mm) + 0.7 * m_mm + 12.0) * math.sqrt(2.0) ** (flank_class - 5)


def iso1328_runout(d, m, key, flank_class=FLANK_CLASS):
    """Runout tolerance F_rT [m] = 0.9 F_pT (:func:`iso1328_cumulative_pitch_um` unrounded, the product rounded
    by 5.2.3; RECALLED, NOT RE-READ, as [ISO1328R] of rv80e_tolerances.toml) of a gear of reference diameter
    ``d`` [m] and normal module ``m`` [m]."""
    _iso1328_scope(d * 1e3, m * 1e3, key)
    return _iso1328_round(0.9 * iso1328_cumulative_pitch_um(d, m, flank_class))


def _um(x):
    return f"{x * 1e6:.3g} um"


def _num(x):
    """A TOML float of x [m], three significant digits (a tolerance is not known better)."""
    return repr(float(f"{x:.3g}"))


def _dist(**kw):
    return "{ " + ", ".join(f'{k} = "{v}"' if k == "dist" else f"{k} = {_num(v)}" for k, v in kw.items()) + " }"


BLANCHE_YANG = ("machining tolerances of cycloid drives are studied at 5-20 um (Blanche & Yang 1989, 'Cycloid drives "
                "with machining tolerances', ASME J. Mech. Trans. Autom. Des. 111, as cited in rd40_tolerances.toml); "
                "the tight end for a ground precision drive")
CLEARANCE_RANGE = ("no fit of reducer needle sets is published; the shipped designs take 0-8 um "
                   "(rv80e_assumed.toml: [0, 3] um from Nabtesco's 0.1-0.3 arcmin mechanical backlash; "
                   "rd40: [3, 8] um); ISO 492 tolerance classes are for bearing rings, and these needle sets run "
                   "on the journal and in the wheel bore, so their clearance is a fit, not an ISO 492 class")


def _normal_pm(key, tol, why):
    """A centred normal of std tol / 3 (+-tol at 3 sigma)."""
    return key, _dist(dist="normal", mean=0.0, std=tol / 3.0), why


def _needle_clearance(key, c, section):
    lo, hi = max(0.0, c - 1.5e-6), c + 1.5e-6
    return key, _dist(dist="uniform", low=lo, high=hi), (
        f"assumed: one selective-fit class of +-1.5 um around the design's {section}.radial_clearance = {_um(c)} "
        f"(support clipped at 0); {CLEARANCE_RANGE}")


def _pin_radius(key, pins):
    it = iso286_it4(2.0 * pins.pin_radius, "pins.pin_radius")
    return key, _dist(dist="uniform", low=-it / 2.0, high=0.0), (
        f"source: ISO 286-1:2010 Table 1, IT4 at the pin diameter {2e3 * pins.pin_radius:.4g} mm = {_um(it)}; "
        f"pins ground to h4 (0 / -IT4 on the diameter, ISO 286-2): radius error in [-IT4/2, 0], one value per "
        f"reducer (one ground batch). Grade h4 assumed (the grade of rd40_tolerances.toml and rv40e_tolerances.toml)")


def _pitch(key, gear, section, what):
    d = gear.module * gear.n_teeth
    f = iso1328_single_pitch(d, gear.module, section)
    return key, _dist(dist="normal", mean=0.0, std=f / 3.0), (
        f"source: ISO 1328-1:2013 eq. (5), flank tolerance class {FLANK_CLASS} (class assumed: the grade 5 of "
        f"rv40e_tolerances.toml, ground gears), {what} d = {d * 1e3:.4g} mm, m_n = {gear.module * 1e3:.4g} mm: "
        f"f_pT = +-{_um(f)}, one draw per tooth")


def _cycloid_rows(design):
    return [
        _normal_pm("eccentricity_error", 3e-6, f"assumed: ground eccentric journal, +-3 um; {BLANCHE_YANG}"),
        ("pin_centre_errors", _dist(dist="normal", mean=0.0, std=1.5e-6),
         f"assumed: jig-ground pin holes, position tolerance (ISO 1101) of diameter 9 um, i.e. +-4.5 um per "
         f"coordinate, drawn for x and y of each pin; {BLANCHE_YANG}"),
        _pin_radius("pin_radius_error", design.pins),
        _normal_pm("equidistant_mod", 3e-6, f"assumed: form-ground wheel profile, equidistant deviation +-3 um; "
                                            f"{BLANCHE_YANG}"),
        _normal_pm("offset_mod", 3e-6, f"assumed: form-ground wheel profile, offset deviation +-3 um; {BLANCHE_YANG}"),
        ("pin_clearance", _dist(dist="truncnormal", mean=5e-6, std=2e-6, low=1e-6, high=10e-6),
         "assumed: assembly clearance at the pins set by selective assembly of pin/wheel groups, mean 5 um in a "
         "[1, 10] um window (as rd40_tolerances.toml; a nominal reducer is not preloaded)"),
        _needle_clearance("bearing_clearance", design.eccentric_bearing.radial_clearance, "eccentric_bearing"),
        _coaxiality("pin_circle_coaxiality_error", design.pins, "output (main-bearing)"),
    ], []


def _coaxiality(key, pins, axis):
    """The pin circle off the ``axis``: coaxiality t = IT5 of the pin circle diameter, each coordinate std t / 6."""
    t = iso286_it5(2.0 * pins.pin_circle_radius, "pins.pin_circle_radius")
    return key, _dist(dist="normal", mean=0.0, std=t / 6.0), (
        f"source: ISO 286-1:2010 Table 1, IT5 at the pin circle diameter {2e3 * pins.pin_circle_radius:.4g} mm = "
        f"{_um(t)}, taken as the coaxiality tolerance t (ISO 1101, a zone of diameter t) of the pin circle to the "
        f"{axis} axis; x and y of the offset, one translation of every pin per reducer (unit m), each normal "
        f"with std t / 6. Grade IT5 assumed (range IT4..IT6; the rule of rd40_tolerances.toml and "
        f"rv80e_tolerances.toml)")


CLASS_NOTE = (f"flank tolerance class {FLANK_CLASS} (class assumed: the grade 5 of rv40e_tolerances.toml and "
              "rv80e_tolerances.toml, ground gears; range 4..6)")
RECALLED = "formula recalled, not re-read from the printed standard, as in rv80e_tolerances.toml"
POS_RULE = ("Grade IT5 assumed (range IT4..IT6 for precision bearing seats and jig-ground hole patterns, an "
            "engineering bracket; the [POS] rule of rv80e_tolerances.toml)")


def _pin_ring(pins):
    """(d, m, z) of the pin ring taken as a gear: the pin circle diameter 2 l_R, module 2 l_R / z_b, z_b pins."""
    d = 2.0 * pins.pin_circle_radius
    return d, d / pins.n_pins, pins.n_pins


def _position(key, size, key_of_size, what, drawn):
    """A position tolerance t = IT5 of ``size`` (ISO 1101, zone of diameter t): each coordinate std t / 6."""
    t = iso286_it5(size, key_of_size)
    return key, _dist(dist="normal", mean=0.0, std=t / 6.0), (
        f"source: ISO 286-1:2010 Table 1, IT5 at {what} = {_um(t)}, taken as the position tolerance t (ISO 1101, "
        f"a zone of diameter t about the true position); {drawn}, normal with std t / 6 (the zone's radius t / 2 "
        f"is three std). {POS_RULE}")


def _rv_rows(design):
    from ..assembly.rv.gear_graph import GearGraph
    pins = design.pins
    d_r, m_r, z_b = _pin_ring(pins)
    z_g = z_b - 1
    d_w = m_r * z_g
    ring = (f"the pin ring (z_b = {z_b} pins, l_R = {pins.pin_circle_radius * 1e3:.4g} mm) taken as an internal gear "
            f"of its own module m = 2 l_R / z_b = {m_r * 1e3:.4g} mm and d = {d_r * 1e3:.4g} mm")
    wheel = (f"the cycloid wheel taken as a gear of the pin ring's module m = 2 l_R / z_b = {m_r * 1e3:.4g} mm and "
             f"z_g = {z_g} teeth, d = {d_w * 1e3:.4g} mm (the analogue: no standard tolerances a cycloid wheel)")
    f_pin = iso1328_single_pitch(d_r, m_r, "pins.pin_circle_radius")
    f_lobe = iso1328_single_pitch(d_w, m_r, "pins.pin_circle_radius")
    f_ha = iso1328_profile_slope(d_w, m_r, "pins.pin_circle_radius")
    a = GearGraph.of(design).crank_radius
    crank_circle = (f"the crank circle diameter 2 a = {2e3 * a:.4g} mm (a the sun--crank-gear centre distance)")
    bore = _position("wheel_bore_position_error", 2.0 * a, "crank_gear (crank circle diameter 2 a)",
                     crank_circle, "the crank bores in each wheel: x and y of crank k's bore in wheel j, the "
                     "wheels' bores drawn independently (no stacked-grinding correlation assumed)")
    if design.wheels.body == "ported":
        bore += ("not drawn: cranks.wheel_bore_errors is not implemented with wheels.body = 'ported' (the ported "
                 "wheel's FE bores sit at their true positions); uncomment with wheels.body = 'rigid'",)
    rows = [
        ("crank_phase_error", _dist(dist="normal", mean=0.0, std=1.0),
         "assumed: eccentric phase of each crank set at assembly, +-3 arcmin (unit: arcmin, not m); no published "
         "figure, as rv40e_tolerances.toml"),
        _normal_pm("crank_eccentricity_error", 3e-6, f"assumed: ground crank journals, +-3 um; {BLANCHE_YANG}"),
        _pin_radius("pin_radius_error", pins),
        _needle_clearance("needle_clearance", design.eccentric_bearing.radial_clearance, "eccentric_bearing"),
        _pitch("sun_pitch_deviation", design.sun_gear, "sun_gear", "sun gear"),
        _pitch("crank_gear_pitch_deviation", design.crank_gear, "crank_gear", "crank spur gears (one set per crank)"),
        ("pin_pitch_deviation", _dist(dist="normal", mean=0.0, std=f_pin / 3.0),
         f"source: ISO 1328-1:2013 eq. (5), {CLASS_NOTE}, {ring}: f_pT = +-{_um(f_pin)}, one draw per pin seat along "
         f"the pin circle (pin k moves tangentially by the accumulated pitch); the class's cumulative pitch "
         f"tolerance F_pT = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12) sqrt(2)^(A - 5) um = "
         f"{iso1328_cumulative_pitch_um(d_r, m_r):.3g} um for comparison ({RECALLED}, [ISO1328R])"),
        _position("pin_radial_position_error", d_r, "pins.pin_circle_radius",
                  f"the pin circle diameter {d_r * 1e3:.4g} mm", "the radial part of each pin seat's deviation "
                  "(the tangential part is pin_pitch_deviation), one draw per pin"),
        bore,
        _position("carrier_bore_position_error", 2.0 * a, "crank_gear (crank circle diameter 2 a)",
                  crank_circle, "the crank bearing seats in the carrier: x and y of each crank's seat"),
        ("profile_equidistant_error", _dist(dist="normal", mean=0.0, std=f_ha / 3.0),
         f"source: ISO 1328-1:2013 clause 5.3.3, profile slope tolerance f_HaT = (0.4 m_n + 0.001 d + 4) "
         f"sqrt(2)^(A - 5) um ({RECALLED}, [ISO1328P]), {CLASS_NOTE}, {wheel}: f_HaT = +-{_um(f_ha)}, the analogue "
         f"tolerance of the ground profile's equidistant deviation, one value per reducer (both wheels ground alike)"),
        ("profile_offset_error", _dist(dist="normal", mean=0.0, std=f_ha / 3.0),
         f"source: ISO 1328-1:2013 clause 5.3.3, profile slope tolerance ({RECALLED}, [ISO1328P]), {CLASS_NOTE}, "
         f"the wheel as for profile_equidistant_error: f_HaT = +-{_um(f_ha)}, the analogue tolerance of the ground "
         f"profile's offset deviation, one value per reducer"),
        ("wheel_lobe_pitch_deviation", _dist(dist="normal", mean=0.0, std=f_lobe / 3.0),
         f"source: ISO 1328-1:2013 eq. (5), {CLASS_NOTE}, {wheel}: f_pT = +-{_um(f_lobe)}, one draw per lobe and "
         f"wheel (lobe j turns by its accumulated pitch); the wheels drawn independently"),
        _coaxiality("pin_circle_coaxiality_error", pins, "main-bearing (carrier)"),
        _runout("sun_runout", design.sun_gear, "sun_gear", "sun gear", "x and y one draw per reducer"),
        _runout("crank_gear_runout", design.crank_gear, "crank_gear", "crank spur gears",
                "x and y one draw per crank, the gears drawn independently"),
    ]
    return rows, []


def _runout(key, gear, section, what, draws):
    d = gear.module * gear.n_teeth
    f = iso1328_runout(d, gear.module, section)
    return key, _dist(dist="normal", mean=0.0, std=f / 6.0), (
        f"source: ISO 1328-1:2013 runout tolerance F_rT = 0.9 F_pT, cumulative pitch tolerance F_pT = (0.002 d + "
        f"0.55 sqrt(d) + 0.7 m_n + 12) sqrt(2)^(A - 5) um ({RECALLED}, [ISO1328R]), {CLASS_NOTE}, {what} "
        f"d = {d * 1e3:.4g} mm, m_n = {gear.module * 1e3:.4g} mm: "
        f"F_pT = {iso1328_cumulative_pitch_um(d, gear.module):.4g} um, F_rT = {_um(f)}; a pitch circle eccentric "
        f"by e_r reads as a runout 2 e_r, so F_rT confines the pitch circle's centre to a circle of diameter F_rT "
        f"about the axis: each coordinate of the eccentricity normal with std F_rT / 6, {draws}")


RV3_NOTE = ("Three-stage design: the input stage (input_pinion, compound_gear) draws no deviation, the RV loader has "
            "no field for it (rvtool/variants/rv_tolerances.py); sun_pitch_deviation and sun_runout are the sun's "
            "on the compound gear's shaft (sun_gear), which meshes the crank gears. Every other field applies as "
            "to a two-stage design (the same sampler).")


def _std_rows(design):
    note = ("not drawn by default: with drawn pitch deviations the shipped STD-39's load-time trochoid check reported "
            "tip interference for every variant (std_involute_tolerances.toml, issue 27); uncomment to draw it")
    return [
        _normal_pm("eccentricity_error", 3e-6, "assumed: ground eccentric shaft (the wheel-ring centre distance), "
                                               f"+-3 um; {BLANCHE_YANG}"),
        _needle_clearance("needle_clearance", design.eccentric_bearing.radial_clearance, "eccentric_bearing"),
    ], [
        _pitch("wheel_pitch_deviation", design.wheel, "wheel", "wheel") + (note,),
        _pitch("ring_pitch_deviation", design.ring, "ring", "ring gear") + (note,),
    ]


def tolerance_template(design, design_file=None):
    """TOML text of a commented tolerance file for ``design`` (a cycloid, RV or small-tooth-difference
    involute design object); ``design_file`` (the design file's name) is named in the header."""
    import textwrap

    from ..assembly.rv.spec import RVDesign
    tail = []
    from ..assembly.spec import CycloidDesign
    from ..assembly.std_spec import StdInvoluteDesign
    if isinstance(design, RVDesign):
        rows, off = _rv_rows(design)
        tail = [RV3_NOTE] if design.topology == "rv3" else []
        fmt = "rvtool/variants/rv_tolerances.py (rvtool designs --format-doc)"
    elif isinstance(design, StdInvoluteDesign):
        rows, off = _std_rows(design)
        fmt = "rvtool/variants/std_tolerances.py"
    elif isinstance(design, CycloidDesign):
        rows, off = _cycloid_rows(design)
        fmt = "rvtool/variants/tolerances.py"
    else:
        raise RvtoolInputError(f"no tolerance template for {type(design).__name__}: its topology has no Monte Carlo")
    of = f" ({design_file})" if design_file else ""
    head = [f"Manufacturing tolerances of {design.name}{of} for the tolerance Monte Carlo of `rvtool analyze` "
            f"(protocol monte_carlo; format: {fmt}). Written by `rvtool new` from the design's own sizes: if "
            "the pin diameter or a gear changes, write the file anew (rvtool new --tolerances-for DESIGN.toml). "
            "Each key's comment says where its grade "
            "comes from: 'source:' a standard's table or formula at this design's sizes, 'assumed:' a chosen "
            "value and the range it was chosen from. SI units (m) unless said. A normal's std is one third of "
            "the +- tolerance (3-sigma process capability). Distributions: normal (mean, std), uniform (low, high), "
            "truncnormal (mean, std, low, high), fixed (value); a key left out draws no deviation."]
    out = [f"# {line}" for para in head for line in textwrap.wrap(para, 110)] + ["", "[tolerances]"]
    for key, value, why, *rest in rows + off:
        out.append("")
        out += [f"# {line}" for line in textwrap.wrap(why + (f"; {rest[0]}" if rest else ""), 110)]
        out.append(f"{'# ' if rest else ''}{key} = {value}")
    for para in tail:
        out += [""] + [f"# {line}" for line in textwrap.wrap(para, 110)]
    return "\n".join(out) + "\n"


def tolerance_path(design_path):
    """The tolerance file beside a design file: ``NAME_tolerances.toml`` for ``NAME.toml`` (what
    ``rvtool new`` writes and ``rvtool analyze`` reads by default)."""
    import os
    stem, _ = os.path.splitext(str(design_path))
    return f"{stem}_tolerances.toml"
