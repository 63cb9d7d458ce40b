"""The TE resolution error of a design against its refined resolution: two designs built and
run through the quasi-static TE protocol (the building is a study's, the metric
:func:`rvtool.protocols.resolution.te_error` the protocol's)."""
import time

import numpy as np

from ..assembly import build
from ..protocols.precision import quasi_static_te
from ..protocols.resolution import te_error
from ..units import ARCSEC_PER_RAD


def te_resolution_error(design, reference, *, points_per_mesh=40, build_kw=None):
    """Quasi-static TE over one mesh cycle (``points_per_mesh`` + 1 points, both ends) at rated
    torque of ``design`` and of ``reference`` (a design at refined resolution). Returns
    ``te_rel_err`` (:func:`te_error`), both TE peak-to-peaks [arcsec], the wall time of each
    sequence [s] and the points."""
    if int(points_per_mesh) < 2:
        from ..errors import RvtoolInputError
        raise RvtoolInputError(f"points_per_mesh = {points_per_mesh} is outside the valid range: an integer >= 2")
    build_kw = build_kw or {}
    runs = {}
    for key, d in (("design", design), ("reference", reference)):
        m = build(d, **build_kw)
        angles = np.arange(points_per_mesh + 1) * m.mesh_period / points_per_mesh
        t0 = time.perf_counter()
        qs = quasi_static_te(m, torque=d.rated_torque, input_angles=angles)
        runs[key] = (np.asarray(qs["te"]), time.perf_counter() - t0)
    te, te_ref = runs["design"][0], runs["reference"][0]
    return {"te_rel_err": te_error(te, te_ref), "te_pp_arcsec": float(np.ptp(te)) * ARCSEC_PER_RAD,
            "te_pp_reference_arcsec": float(np.ptp(te_ref)) * ARCSEC_PER_RAD,
            "wall_s": runs["design"][1], "reference_wall_s": runs["reference"][1],
            "points": points_per_mesh + 1, "interval": "one cycloid mesh cycle at rated torque"}
