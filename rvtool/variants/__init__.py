"""Manufacturing variants, tolerance Monte Carlo and parameter sweeps.

* :mod:`.variant`: one variant (a design deviation) and its figures protocol,
* :mod:`.tolerances`: tolerance distributions and sampling,
* :mod:`.montecarlo`: the resumable Monte Carlo with confidence intervals,
* :mod:`.sweep`: parameter grids on Dask,
* :mod:`.batched`: the figures protocol on batched copies in one Exudyn system.
"""
from .variant import Variant, VariantProtocol, variant_figures, variant_lost_motion

__all__ = ["Variant", "VariantProtocol", "variant_figures", "variant_lost_motion"]
