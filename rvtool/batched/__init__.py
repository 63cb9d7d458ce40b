"""Batched variants: B manufacturing variants of one design in ONE Exudyn system.

:func:`~rvtool.batched.assembly.build_batched` assembles the copies (one kernel launch
per contact family for all copies, block-diagonal tangent through per-copy
elements); the solver is :class:`rvtool.solver.batched.BatchedStaticSolver` and the
figures protocol :func:`rvtool.variants.batched.batched_variant_figures`.
"""
from .assembly import BatchedCycloidModel, build_batched
from ..solver.copy_evaluator import BatchContactEvaluator, CopyBlockAssembler

__all__ = ["BatchedCycloidModel", "build_batched", "BatchContactEvaluator", "CopyBlockAssembler"]
