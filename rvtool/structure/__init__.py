"""Structural operators at contact ports (Section "Structural operators, contact ports, and coupled deformation").

Model: :mod:`fe_model` (NGSolve parent: K, M, C, port selection, supports);
reductions: :mod:`craig_bampton` (Eq. cb_reduction), :mod:`port_reduction` (retained
and residual attachment modes, port maps, local correction), :mod:`floating` (bases for
floating flexible bodies); static operators: :mod:`static` (Eqs. body_compliance,
port_condensation, weak_coupling, inertia relief); runtime map: :mod:`port_map`
(Eq. port_runtime_transform); checks and responses: :mod:`definiteness`,
:mod:`trace_check`, :mod:`response`. The Exudyn side is
``exudyn_user_elements.reduced_structure``.
"""
from .craig_bampton import CraigBamptonModel, craig_bampton, craig_bampton_matrices
from .definiteness import GROUNDING_TOLERANCE, grounding_ratio, require_grounded, require_positive_definite
from .fe_model import (AnnularHousingSpec, ElasticMaterial, FEModel, NodalClamp, NodalPort, NodalSpring, PortGroup,
                       RayleighDamping, annular_housing, fe_model_from_geometry, fe_model_from_mesh, generate_mesh)
from .floating import floating_basis
from .port_map import expand, expanded_map, reduce_force, reduce_tangent
from .port_reduction import ParentModes, PortReducedModel, PortReductionSpec, parent_modes, reduce_ports
from .response import modal_frf, parent_port_frf_matrix, port_row_errors, relative_l2, static_error
from .static import (DelayedOffsetFeedback, InertiaReliefCompliance, OffsetFeedbackSpec, SupportedCompliance,
                     condense_ports, relaxed_offset_update)
from .trace_check import LinearTraces, radial_traces, trace_consistency

__all__ = [
    "AnnularHousingSpec", "CraigBamptonModel", "DelayedOffsetFeedback", "ElasticMaterial", "FEModel",
    "GROUNDING_TOLERANCE", "InertiaReliefCompliance", "LinearTraces", "NodalClamp", "NodalPort", "NodalSpring",
    "OffsetFeedbackSpec", "ParentModes", "PortGroup", "PortReducedModel", "PortReductionSpec", "RayleighDamping",
    "SupportedCompliance", "annular_housing", "condense_ports", "craig_bampton", "craig_bampton_matrices", "expand",
    "expanded_map", "fe_model_from_geometry", "fe_model_from_mesh", "floating_basis", "generate_mesh",
    "grounding_ratio", "modal_frf", "parent_modes", "parent_port_frf_matrix", "port_row_errors", "radial_traces",
    "reduce_force", "reduce_ports", "reduce_tangent", "relative_l2", "relaxed_offset_update",
    "require_grounded", "require_positive_definite", "static_error", "trace_consistency",
]
