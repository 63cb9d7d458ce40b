"""A manufacturing variant of a cycloid design: deviations from the nominal design (all SI, see
:class:`Variant`), applied with :meth:`Variant.apply` to give the variant's design. Data, like a
design: the samplers (:mod:`rvtool.variants`) draw them, the builders and the solvers' copy
parameters (:mod:`rvtool.solver.device_copies`) apply them."""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative


@dataclass(frozen=True, kw_only=True)
class Variant:
    """Deviations of one manufactured reducer from the nominal design (see module docstring)."""
    index: int = 0
    eccentricity_error: float = 0.0
    pin_centre_errors: tuple | None = None
    pin_radius_error: float = 0.0
    equidistant_mod: float = 0.0
    offset_mod: float = 0.0
    pin_clearance: float = 0.0
    bearing_clearance: float | None = None

    def __post_init__(self):
        for nm in ("eccentricity_error", "pin_radius_error", "equidistant_mod", "offset_mod", "pin_clearance"):
            check_finite(nm, getattr(self, nm))
        if self.bearing_clearance is not None:
            check_nonnegative("bearing_clearance", self.bearing_clearance)
        if self.pin_centre_errors is not None:
            e = np.asarray(self.pin_centre_errors, float)
            if e.ndim != 2 or e.shape[1] != 2:
                raise RvtoolInputError(f"pin_centre_errors must have shape (n_pins, 2); got {e.shape}")
            check_finite("pin_centre_errors", e)

    def apply(self, design):
        """The design of this variant of ``design`` (deviations written into its sections)."""
        from ..assembly.spec import replace
        return replace(design, **self.sections(design))

    def sections(self, design):
        """The changed sections :meth:`apply` writes into ``design`` (the ``replace`` form), checked."""
        w, prof = design.wheels, design.profile
        e_g = prof.generating_eccentricity
        e = e_g + self.eccentricity_error
        if e <= 0:
            raise RvtoolInputError(f"eccentricity_error = {self.eccentricity_error} m leaves a non-positive eccentricity; "
                                   f"valid range ({-e_g}, inf) m")
        sections = {"wheels": {"eccentricity": e, "clearance": w.clearance + self.pin_clearance},
                    "profile": {"generating_eccentricity": e_g,
                                "equidistant_mod": prof.equidistant_mod + self.equidistant_mod,
                                "offset_mod": prof.offset_mod + self.offset_mod}}
        if self.bearing_clearance is not None:
            sections["eccentric_bearing"] = {"radial_clearance": self.bearing_clearance}
        pins = {}
        if self.pin_centre_errors is not None:
            e = np.asarray(self.pin_centre_errors, float)
            if e.shape != (design.pins.n_pins, 2):
                raise RvtoolInputError(f"pin_centre_errors must have shape ({design.pins.n_pins}, 2); got {e.shape}")
            pins["centre_errors"] = tuple(map(tuple, e))
        if self.pin_radius_error != 0.0:
            if design.pins.pin_radius + self.pin_radius_error <= 0:
                raise RvtoolInputError(f"pin_radius_error = {self.pin_radius_error} m; valid range "
                                       f"({-design.pins.pin_radius}, inf) m")
            pins["radius_error"] = design.pins.radius_error + self.pin_radius_error
        if pins:
            sections["pins"] = pins
        return sections
