"""The keys of the tolerance files (``<design>_tolerances.toml``): units and meanings, in draw order, of the
cycloid (:mod:`rvtool.variants.tolerances`), RV (:mod:`rvtool.variants.rv_tolerances`) and small-tooth-difference
involute (:mod:`rvtool.variants.std_tolerances`) samplers."""

CYCLOID_TOLERANCE_KEYS = {
    "eccentricity_error": ("m", "added to the assembly eccentricity e (the profile keeps its own)",
                           "the variant's eccentricity"),
    "pin_centre_errors": ("m", "drawn independently for the x and the y of every ring-pin centre",
                          "the variant's pin centres"),
    "pin_radius_error": ("m", "actual minus nominal pin radius, one value per reducer (one ground batch)",
                         "the variant's pin radius"),
    "equidistant_mod": ("m", "profile grinding deviation added to the design's equidistant modification",
                        "profile.equidistant_mod (added)"),
    "offset_mod": ("m", "profile grinding deviation added to the design's offset modification",
                   "profile.offset_mod (added)"),
    "pin_clearance": ("m", "gap added at every pin contact", "the variant's pin contacts"),
    "bearing_clearance": ("m", "radial clearance of the eccentric bearing, replacing the design's (support >= 0)",
                          "eccentric_bearing.radial_clearance"),
    "pin_circle_coaxiality_error": ("m", "x and y of the pin circle's centre off the output (main-bearing) axis: one "
                                    "translation per reducer, common to every ring-pin centre and fixed in the "
                                    "housing frame", "the variant's pin centres (added)"),
}
"""The keys of a cycloid tolerance file in the order a variant draws them (:data:`rvtool.variants.tolerances.FIELDS`
is this order): (unit, meaning, what it changes). A new key goes at the end, so that the earlier keys' draws of a
seed stay as they were."""

STD_TOLERANCE_KEYS = {
    "eccentricity_error": ("m", "added to the wheel-ring centre distance, one value per reducer",
                           "wheels.eccentricity (added)"),
    "needle_clearance": ("m", "radial clearance of the needle sets, one value per reducer (support >= 0)",
                         "eccentric_bearing.radial_clearance"),
    "wheel_pitch_deviation": ("m", "single pitch deviation of each wheel tooth (minus their mean)",
                              "wheel.single_pitch_deviations"),
    "ring_pitch_deviation": ("m", "single pitch deviation of each ring tooth (minus their mean)",
                             "ring.single_pitch_deviations"),
}
"""The keys of a small-tooth-difference involute tolerance file in draw order
(:data:`rvtool.variants.std_tolerances.STD_FIELDS` is this order): (unit, meaning, the design key it writes)."""

RV_TOLERANCE_KEYS = {
    "crank_phase_error": ("arcmin", "eccentric phase error of each crank (one draw per crank)",
                          "cranks.phase_errors_deg"),
    "crank_eccentricity_error": ("m", "e_k - e of each crank (one draw per crank)", "cranks.eccentricity_errors"),
    "pin_radius_error": ("m", "actual minus nominal pin radius, one value per reducer", "pins.radius_error"),
    "needle_clearance": ("m", "radial clearance of the needle sets, one value per reducer (support >= 0)",
                         "eccentric_bearing.radial_clearance"),
    "sun_pitch_deviation": ("m", "single pitch deviation of each sun tooth (minus their mean)",
                            "sun_gear.single_pitch_deviations"),
    "crank_gear_pitch_deviation": ("m", "single pitch deviation of each crank gear's teeth (per crank, minus its "
                                   "mean)", "cranks.gear_pitch_deviations"),
    "pin_pitch_deviation": ("m", "single pitch deviation of each pin seat along the pin circle; pin k moves "
                            "tangentially by the accumulated pitch", "pins.centre_errors"),
    "pin_radial_position_error": ("m", "radial deviation of each pin seat from the pin circle (outward positive)",
                                  "pins.centre_errors"),
    "wheel_bore_position_error": ("m", "x and y deviation of each crank's bore in each wheel (wheel frame)",
                                  "cranks.wheel_bore_errors"),
    "carrier_bore_position_error": ("m", "x and y deviation of each crank's bearing seat in the carrier",
                                    "cranks.carrier_bore_errors"),
    "profile_equidistant_error": ("m", "equidistant deviation of the ground wheel profile, one value per reducer "
                                  "(positive removes material)", "profile.equidistant_mod (added)"),
    "profile_offset_error": ("m", "offset deviation of the ground wheel profile, one value per reducer",
                             "profile.offset_mod (added)"),
    "wheel_lobe_pitch_deviation": ("m", "single pitch deviation of each lobe of each cycloid wheel (per wheel, minus "
                                   "its mean) on the wheel's reference circle R_z z_g / z_b; lobe j turns by the "
                                   "accumulated pitch", "wheels.lobe_pitch_deviations"),
    "pin_circle_coaxiality_error": ("m", "x and y of the pin circle's centre off the main-bearing (carrier) axis: "
                                    "one translation per reducer, common to every ring-pin seat and fixed in the "
                                    "housing frame", "pins.centre_errors (added)"),
    "sun_runout": ("m", "x and y of the sun's pitch-circle eccentricity (runout), one per reducer: tooth k's flank "
                   "moves along the line of action by e_x cos(2 pi k / z) + e_y sin(2 pi k / z), written as its "
                   "first differences", "sun_gear.single_pitch_deviations (added)"),
    "crank_gear_runout": ("m", "x and y of each crank gear's pitch-circle eccentricity (one per crank), written as "
                          "the sun's", "cranks.gear_pitch_deviations (added)"),
}
"""The keys of an RV tolerance file in the order a variant draws them (:data:`rvtool.variants.rv_tolerances.RV_FIELDS`
is this order): (unit of the drawn value, meaning, the design key it writes), for the format documentation
(:func:`rvtool.designs.format.format_doc`). A new key goes at the end, so that the earlier keys' draws of a seed
stay as they were."""
