"""Declared allowables of a design review (a component spec read from an ``[allowables]`` table,
e.g. ``rd40_allowables.toml`` beside this module); the datasheet
(:func:`rvtool.protocols.datasheet.datasheet`) judges the computed figures against them."""
import tomllib
from dataclasses import dataclass

from ..assembly.spec import build_section
from ..errors import RvtoolInputError
from ..structure.pin_beam import PinSupport
from ..validation import check_positive


@dataclass(frozen=True, kw_only=True)
class Allowables:
    """Declared allowables of a design review (SI units).

    min_torsional_stiffness: lowest accepted catalogue secant stiffness [N m/arcmin].
    max_lost_motion: largest accepted lost motion at +-3 % rated torque [arcmin].
    max_hertz_pins, max_hertz_output_pins, max_hertz_needles: largest accepted Hertz peak
        pressure per family [Pa].
    max_pin_bending_stress: largest accepted bending stress sigma = M/W of a ring pin or an
        output pin at the rated state [Pa].
    max_resolution_error: largest accepted relative error of the rated peak pin force at the
        default profile resolution against the refined one [-] (the project's 0.1 % statement).
    max_hysteresis_loss: largest accepted hysteresis loss (loop width at zero torque of a closed
        +-T_rated cycle) [arcmin]; None: not declared (the figure is informative).
    min_bearing_life: smallest accepted ISO 281 rating life L10h of any bearing at the rated
        torque and speed [h]; None: not declared.
    assumed_ring_pin_support, assumed_output_pin_support: the support
        (:class:`~rvtool.structure.pin_beam.PinSupport`, sub-tables ``[allowables.assumed_ring_pin_support]``,
        ...) the review assumes for the pin bending stress where the design's pins are rigid
        (a declared support of the design takes precedence); None: the stress is not computed.
    """
    min_torsional_stiffness: float
    max_lost_motion: float
    max_hertz_pins: float
    max_hertz_output_pins: float
    max_hertz_needles: float
    max_pin_bending_stress: float
    max_resolution_error: float = 1e-3
    max_hysteresis_loss: float | None = None
    min_bearing_life: float | None = None
    assumed_ring_pin_support: PinSupport | None = None
    assumed_output_pin_support: PinSupport | None = None

    def __post_init__(self):
        for name in ("min_torsional_stiffness", "max_lost_motion", "max_hertz_pins", "max_hertz_output_pins",
                     "max_hertz_needles", "max_pin_bending_stress", "max_resolution_error"):
            check_positive(name, getattr(self, name))
        for name in ("max_hysteresis_loss", "min_bearing_life"):
            if getattr(self, name) is not None:
                check_positive(name, getattr(self, name))
        for name in ("assumed_ring_pin_support", "assumed_output_pin_support"):
            v = getattr(self, name)
            if isinstance(v, dict):
                v = build_section(PinSupport, name, v)
                object.__setattr__(self, name, v)
            if v is not None and (not isinstance(v, PinSupport) or not v.elastic):
                raise RvtoolInputError(f"{name} = {v!r} must be a support table with model 'cantilever', "
                                       "'simply_supported' or 'clamped_clamped'")


def load_allowables(path):
    """:class:`Allowables` from a TOML file with an ``[allowables]`` table (errors name ``allowables.<key>``)."""
    with open(path, "rb") as fh:
        table = tomllib.load(fh)
    if not isinstance(table.get("allowables"), dict):
        raise RvtoolInputError(f"{path} has no [allowables] table; valid: an allowables file with the keys of "
                               "rvtool/designs/rd40_allowables.toml")
    return build_section(Allowables, "allowables", table["allowables"])
