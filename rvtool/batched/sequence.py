"""Quasi-static TE with many input angles per Newton solve (angle-batched sequence).

The quasi-static TE of :func:`rvtool.protocols.precision.quasi_static_te` is a
sequence of N equilibria at prescribed input angles, each warm-started from the
previous one. Solved one at a time, every Newton iteration pays the fixed costs of
a solve (Exudyn's solver set-up, one Python round trip and one kernel launch per
contact family) for one reducer's ~100 contact rows, which is what limits the
sequential path on a CPU (2.6 ms per equilibrium on RD-40, launch and Python
overhead dominating).

Here the N angles are cut into B contiguous segments, and B copies of the same
reducer (one Exudyn system, :func:`rvtool.batched.assembly.build_batched` with B
nominal variants) march through their segments side by side: step k solves the
k-th angle of every segment in ONE batch Newton solve (one launch per family for
all B copies, block-diagonal tangent). Copies are independent, so each copy's
equilibrium is exactly the one the sequential path finds at that angle (the same
residual, tolerances and plausibility bounds); only the start of each segment is a
cold start (the stiffness homotopy of :class:`BatchedStaticSolver`) instead of a
warm start. Each copy's warm start extrapolates its elastic deviation from its two
previous points (``predictor="secant"``).

``workers`` > 1 splits the segments over that many processes (each builds its own
batched system): on a CPU the kernels of one process run on one core.

The march itself is the replica backend's (:class:`rvtool.solver.backends.ReplicaBackend`) and
the TE the protocol's (:func:`rvtool.protocols.precision.equilibria_te`, the end of
:func:`~rvtool.protocols.precision.quasi_static_te`); the worker processes build the model
(one build per process, none here).
"""

from ..protocols.precision import equilibria_te
from ..solver.backends import EquilibriumBatch, ReplicaBackend


def batched_quasi_static_te(design, *, torque, input_angles, copies=None, workers=1, device="cpu", build_kw=None,
                            predictor="secant", abs_tol=1e-4):
    """Quasi-static TE of ``design`` (any topology) at ``input_angles`` [rad] under output torque
    ``torque`` [N m] on the replica backend with B = ``copies`` angle segments side by side in
    ``workers`` processes (see :class:`~rvtool.solver.backends.ReplicaBackend` for copies and abs_tol).

    Returns the keys of :func:`rvtool.protocols.precision.quasi_static_te` (``theta_in`` are
    the solved angles, ``te`` [rad], ``peak_loads`` per family [N], ``stats``, ``wall_s``)
    plus ``copies``, ``workers``, ``build_s`` (largest per-process build time [s]) and ``split``.
    build_kw: builder options (``regularization``)."""
    kw = dict(build_kw or {})
    backend = ReplicaBackend(copies=copies, workers=workers, build_kw=kw, device=device, predictor=predictor,
                             abs_tol=abs_tol)
    batch = EquilibriumBatch(input_angles=input_angles, torque=torque)
    # the workers build their own models (replicate names what it cannot copy); this process builds none
    eq = backend.solve_design(design, batch)
    out = equilibria_te(eq, design.ratio, {"requested": "replica", "ran": "replica", "not_taken": {}})
    st = out["stats"]
    out.update(copies=st.pop("copies"), workers=st.pop("workers"), build_s=st.pop("build_s"), split=st.pop("split"))
    return out
