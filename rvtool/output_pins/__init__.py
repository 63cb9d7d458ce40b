"""Output pins: flange pins in wheel holes (paper, subsection "Output-pin
transfer and a reproducible two-wheel coupling").

* :mod:`.spec` - mechanism inputs (frozen dataclasses), the study inputs of Table (tab:supp_pin_inputs)
* :mod:`.calibration` - Hertz reference approach and k = F_ref / delta_ref^{10/9}
* :mod:`.shared_pin` - shared-pin condensation on the nine coordinates, scaling of Eq. (supp_pin_scaling)
* :mod:`.explicit_sleeve` - the explicit-sleeve alternative with a flexible shaft-to-sleeve interface
* :mod:`.diagnostics` - reaction balance, central differences, complex step, separate moment assembly
* :mod:`.evaluator` - the family behind the contact-element evaluator protocol
"""
from .calibration import (PIN_EXPONENT, calibrate_pin_coefficient, contact_modulus, hertz_calibrated_coefficient,
                          hertz_pin_in_hole_approach)
from .spec import (ExplicitSleeveInterface, OutputPinMechanism, PinMode, SharedPinCompliance, SleeveFit,
                   shared_pin_study_mechanism)
from .shared_pin import SharedPinModel, SharedPinResponse, scaled_tangent, scaling_matrix
from .explicit_sleeve import ExplicitSleeveEvaluator, ExplicitSleeveModel
from .evaluator import GROUND, OutputPinEvaluator

__all__ = ["PIN_EXPONENT", "calibrate_pin_coefficient", "contact_modulus", "hertz_calibrated_coefficient",
           "hertz_pin_in_hole_approach", "ExplicitSleeveInterface", "OutputPinMechanism", "PinMode",
           "SharedPinCompliance", "SleeveFit", "shared_pin_study_mechanism", "SharedPinModel", "SharedPinResponse",
           "scaled_tangent", "scaling_matrix", "ExplicitSleeveModel", "ExplicitSleeveEvaluator", "GROUND", "OutputPinEvaluator"]
