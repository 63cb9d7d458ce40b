"""The evaluator scaffolding shared by the two-body contact families whose rows are evaluated
by one Warp launch (or their NumPy reference) and scattered by a
:class:`~rvtool.contact.assembly.PairAssembler`: cycloid--pin meshes
(:class:`~rvtool.contact.cycloid_set.CycloidPinSet`) and involute gear meshes
(:class:`~rvtool.contact.involute_set.InvoluteContactSet`).

A family builds its parameter rows, then calls :meth:`PairFamilySet.init_evaluation` with its
body pairs; it provides ``self._kernel`` (backend "warp": ``evaluate(pose, vel)`` and
``set_velocity_tangent(on)``) and :meth:`PairFamilySet.reference` (backend "numpy"). The
protocol of :class:`exudyn_user_elements.contact_element.ContactElement` (``raw``,
``evaluate``, ``commit``, ``set_velocity_tangent``, ``ids``, ``history``) is implemented here
once. The ground is the padded last row of the pose arrays (index ``n_bodies``).
"""
import numpy as np

from ..errors import RvtoolInputError
from .assembly import PairAssembler
from .evaluator import Evaluation, all_finite

BACKENDS = ("warp", "numpy")
PRECISIONS = ("float64", "float32")


class NoHistory:
    """Committed history of a family without history variables (no arrays)."""


def check_backend(backend, precision):
    """Named errors for an unknown backend or precision."""
    if backend not in BACKENDS:
        raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are {list(BACKENDS)}")
    if precision not in PRECISIONS:
        raise RvtoolInputError(f"precision = {precision!r} is not valid; valid choices are {sorted(PRECISIONS)}")


class PairFamilySet:
    """Evaluator protocol of a two-body contact family (see the module docstring)."""

    velocity_tangent = True

    def init_evaluation(self, body_a, body_b, n_bodies):
        """Assembler of the rows' body pairs (ground = ``n_bodies``), empty history and the padded
        pose and velocity buffers."""
        self.n_bodies = n_bodies
        self.history = NoHistory()
        self.assembler = PairAssembler(body_a, body_b, n_bodies)
        self._pose = np.zeros((n_bodies + 1, 3))
        self._vel = np.zeros((n_bodies + 1, 3))

    def reference(self, pose, vel):
        """(Q, dQ/dq, dQ/dv, obs) per row from the NumPy reference at padded poses and velocities."""
        raise NotImplementedError

    def set_velocity_tangent(self, on):
        """Velocity tangent dQ/dv on (default) or off (static solves: :meth:`raw` returns None for it
        and the kernel skips the velocity seeds)."""
        self.velocity_tangent = bool(on)
        if self.backend == "warp":
            self._kernel.set_velocity_tangent(on)

    def raw(self, pose, vel):
        """Per-row (Q (N, 6), dQdq (N, 6, 6), dQdv (N, 6, 6) or None, obs) at body poses (nb, 3)."""
        self._pose[:-1] = pose
        self._vel[:-1] = vel
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose, self._vel)
        Q, dq, dv, obs = self.reference(self._pose, self._vel)
        return Q, dq, (dv if self.velocity_tangent else None), obs

    def evaluate(self, pose, vel, history=None, check=True):
        if check:
            for nm, a in (("pose", pose), ("vel", vel)):
                a = np.asarray(a)
                if a.shape != (self.n_bodies, 3) or not np.all(np.isfinite(a)):
                    raise RvtoolInputError(f"{nm} must be a finite array of shape ({self.n_bodies}, 3); got {a.shape}")
        Qc, dq, dv, obs = self.raw(pose, vel)
        dv = np.zeros_like(dq) if dv is None else dv
        finite = all_finite(Qc, dq, dv)
        return Evaluation(self.assembler.vector(np.asarray(Qc, float)), self.assembler.matrix(np.asarray(dq, float)),
                          self.assembler.matrix(np.asarray(dv, float)), np.array(obs, float), (), finite)

    def commit(self, pose, vel, evaluation=None):
        """No history to commit: the observations at the accepted state."""
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return np.array(self.raw(pose, vel)[3], float)
