"""Shared-pin condensation on the nine coordinates of Eq. (supp_pin_coordinates).

A :class:`SharedPinModel` evaluates every pin of a shared-mode
:class:`~rvtool.output_pins.spec.OutputPinMechanism` between one flange
(body 0) and two wheels (bodies 1, 2) at absolute poses

    q = (x_f, y_f, theta_f, x_0, y_0, theta_0, x_1, y_1, theta_1)  [m, rad],

and returns the reactions Q = (F_x, F_y, M_z) about each body origin, the
solver-sign tangent K_q = -dQ/dq (the forward-mode derivative of the
production force map, see :mod:`warp_contacts.output_pins_ref`) and the
local closure quantities. The work-conjugate scaling of Eq.
(supp_pin_scaling) is :func:`scaling_matrix`.
"""
from dataclasses import dataclass

import numpy as np

from warp_contacts import output_pins_ref as ref

from ..errors import RvtoolInputError
from ..validation import check_choice, check_finite, check_positive, check_shape
from .spec import OutputPinMechanism, PinMode

BACKENDS = ("warp", "numpy")


@dataclass(frozen=True)
class SharedPinResponse:
    """Result of one shared-pin evaluation (sums over pins where noted).

    q (9,) [m, rad]; Q (9,) [N, N m], summed over pins; K_q (9, 9) = -dQ/dq;
    wheel_forces (2,): magnitude of the resultant force on each wheel [N];
    slice_force (n_pins, 2, ns) [N]; slice_approach (n_pins, 2, ns): effective
    approach d - u_p,i of the re-evaluated law [m]; geometric_approach: d at the
    final sleeve position [m]; slice_normal (n_pins, 2, ns, 2): direction of the
    force on the wheel; sleeve_offset (n_pins, 2) [m]; closure_force (n_pins, 2):
    clipped F^c [N]; station_deflection (n_pins, 2): u_p [m]; open_tangent
    (n_pins, 2): K_i [N/m]; tilt_moments (3, 2): (M_x, M_y) per body [N m];
    slice_force_tangent (n_pins, 2, ns, 2, 9) or None; sleeve_tangent (n_pins, 2, 9).
    """
    q: np.ndarray
    Q: np.ndarray
    K_q: np.ndarray
    wheel_forces: np.ndarray
    slice_force: np.ndarray
    slice_approach: np.ndarray
    geometric_approach: np.ndarray
    slice_normal: np.ndarray
    sleeve_offset: np.ndarray
    closure_force: np.ndarray
    station_deflection: np.ndarray
    open_tangent: np.ndarray
    tilt_moments: np.ndarray
    slice_force_tangent: np.ndarray | None
    sleeve_tangent: np.ndarray

    def wheel_force_derivative(self, wheel, coordinate):
        """dF_i/dq_j of the resultant magnitude F_i = |f_i| (f_i: force on wheel i) from the tangent."""
        f = self.Q[3 + 3 * wheel:5 + 3 * wheel]
        df = -self.K_q[3 + 3 * wheel:5 + 3 * wheel, coordinate]
        norm = np.linalg.norm(f)
        return float(f @ df / norm) if norm > 0 else 0.0


def scaling_matrix(radius):
    """S = diag(1, 1, 1/R, 1, 1, 1/R, 1, 1, 1/R) of Eq. (supp_pin_scaling) (R [m])."""
    check_positive("radius", radius)
    return np.diag([1.0, 1.0, 1.0 / radius] * 3)


def scaled_tangent(K, radius):
    """K_hat = S K S of Eq. (supp_pin_scaling): every entry in N/m."""
    S = scaling_matrix(radius)
    return S @ np.asarray(K, float) @ S


def as_poses(q):
    """(3, 3) body poses from the nine coordinates of Eq. (supp_pin_coordinates)."""
    q = np.asarray(q)
    if q.shape != (9,):
        raise RvtoolInputError(f"q must have the 9 coordinates (x_f, y_f, theta_f, x_0, ..., theta_1); got shape {q.shape}")
    return q.reshape(3, 3)


class SharedPinModel:
    """Production shared-pin force and directional-tangent function for one mechanism.

    backend "warp" (one kernel launch, default) or "numpy" (the reference);
    precision "float64" (default) or "float32"; device "cpu" or "cuda:N".
    slice_tangent: also return per-slice force tangents (separate moment assembly).
    """

    def __init__(self, mechanism: OutputPinMechanism, *, backend="warp", precision="float64", device="cpu",
                 slice_tangent=False):
        if not isinstance(mechanism, OutputPinMechanism) or mechanism.mode != PinMode.SHARED:
            raise RvtoolInputError(f"mechanism must be an OutputPinMechanism with mode 'shared'; got "
                                   f"{getattr(mechanism, 'mode', type(mechanism).__name__)!r}")
        check_choice("backend", backend, BACKENDS)
        check_choice("precision", precision, ("float64", "float32"))
        if backend == "numpy" and precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")
        self.mechanism = mechanism
        self.backend = backend
        self.precision = precision
        self.fparams, self.iparams = mechanism.packed(0, (1, 2))
        self.stations = mechanism.stations
        self.radius = mechanism.pin_circle_radius
        self.slice_tangent = slice_tangent
        if backend == "warp":
            from warp_contacts.output_pins import OutputPinKernel
            self._kernel = OutputPinKernel(self.fparams, self.iparams, self.stations, 3, "shared", precision, device,
                                           slice_tangent=slice_tangent)

    def raw(self, q, tilt=None):
        """Per-pin results in the layout of :func:`warp_contacts.output_pins_ref.evaluate_shared`."""
        pose = as_poses(np.asarray(q, float))
        check_finite("q", pose)
        if tilt is not None:
            tilt = check_shape("tilt", np.asarray(tilt, float), (3, 2))
        if self.backend == "warp":
            r = self._kernel.evaluate(pose, tilt)
            ns = self.stations.size
            out = {k: np.array(v, np.float64) for k, v in r.items()}
            out["slices"] = out["slices"].reshape(-1, 2, ns, ref.N_SLICE_COLS)
            if "slice_force_tangent" in out:
                out["slice_force_tangent"] = out["slice_force_tangent"].reshape(-1, 2, ns, 2, 9)
            return out
        return ref.evaluate_shared(pose, self.fparams, self.iparams, self.stations, tilt=tilt)

    def evaluate(self, q, tilt=None):
        """:class:`SharedPinResponse` at the nine coordinates ``q`` (tilts (3, 2) [rad] optional)."""
        r = self.raw(q, tilt)
        Q = r["Q"].sum(axis=0)
        K = -r["dQdq"].sum(axis=0)
        S = r["slices"]
        pin = r["pin"]
        wf = np.array([np.linalg.norm(Q[3:5]), np.linalg.norm(Q[6:8])])
        sft = r.get("slice_force_tangent") if self.slice_tangent else None
        return SharedPinResponse(
            q=np.array(q, float), Q=Q, K_q=K, wheel_forces=wf, slice_force=S[..., ref.S_FORCE],
            slice_approach=S[..., ref.S_APPROACH], geometric_approach=S[..., ref.S_GEOM],
            slice_normal=S[..., ref.S_NX:ref.S_NY + 1], sleeve_offset=pin[:, ref.U_X:ref.U_Y + 1],
            closure_force=pin[:, ref.FC0:ref.FC1 + 1], station_deflection=pin[:, ref.UP0:ref.UP1 + 1],
            open_tangent=pin[:, ref.K0:ref.K1 + 1], tilt_moments=r["tilt_moments"].sum(axis=0),
            slice_force_tangent=sft, sleeve_tangent=r["sleeve_tangent"])

    def forces(self, q, tilt=None):
        """Generalized forces Q (9,) summed over pins."""
        return self.raw(q, tilt)["Q"].sum(axis=0)
