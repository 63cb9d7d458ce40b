"""Resolution error of a design's quasi-static TE: the TE over one mesh cycle at the design's own
numerical settings against the same cycle at a refined reference design (same points, so the error
is read at common samples without interpolation). Topology-neutral: the caller names the
reference (e.g. the RV's ``design.refined()`` with the analytic profile search) and runs both
(:func:`rvtool.analysis.resolution.te_resolution_error`)."""
import numpy as np


def te_error(te, te_ref):
    """Relative TE error of ``te`` against ``te_ref`` (the same input angles): the larger of the
    pointwise error with both means removed and the peak-to-peak error, over the reference's
    peak-to-peak (the definition of cases/benchmarks/work_precision_rv.py)."""
    te, te_ref = np.asarray(te), np.asarray(te_ref)
    pp_ref = float(np.ptp(te_ref))
    e = (te - te.mean()) - (te_ref - te_ref.mean())
    return float(max(np.max(np.abs(e)), abs(np.ptp(te) - pp_ref)) / pp_ref)
