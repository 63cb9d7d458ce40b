"""Batched variants: B manufacturing variants of one design in ONE Exudyn system.

:func:`~rvtool.batched.assembly.build_batched` assembles the copies (one kernel launch
per contact family for all copies, block-diagonal tangent through per-copy
elements); :func:`~rvtool.batched.protocol.batched_variant_figures` runs the
per-variant figures protocol of :func:`rvtool.variants.variant_figures` on all
copies at once, with per-copy plausibility and a per-variant fallback.
"""
from .assembly import BatchedCycloidModel, build_batched
from .evaluator import BatchContactEvaluator, CopyBlockAssembler
from .protocol import batched_variant_figures
from .solver import BatchedStaticSolver

__all__ = ["BatchedCycloidModel", "build_batched", "BatchContactEvaluator", "CopyBlockAssembler",
           "BatchedStaticSolver", "batched_variant_figures"]
