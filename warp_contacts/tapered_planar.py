"""Warp kernels of the tapered-roller family's planar use: the mapping between the planar bodies
(x, y, theta) of each mounting and the rollers' relative states, and back to the mounting's
generalized forces and tangent, on the device (no per-roller download).

NumPy reference: :meth:`rvtool.bearings.tapered_set.TaperedBearingSet.raw` (the planar state and
the per-mounting sums; tests/test_tapered_planar.py). Per roller j of mounting k (bodies A inner,
B outer, ring-centre arms a = R(theta_A) xi_A, b = R(theta_B) xi_B):

* ``planar_state`` (one thread per roller): r = (x_A + a) - (x_B + b), its rate, and the cage
  angle psi_j = phase_j + ((1 - gamma) theta_A + (1 + gamma) theta_B) / 2 with its rate, written
  into the roller kernel's inputs (:class:`warp_contacts.tapered_rollers.TaperedRollerKernel`);
* ``planar_rows`` (one thread per mounting, its rollers summed in roller order): F, K2, C2 and
  the cage sensitivities summed over the rollers, dr/dq = [I, perp(a), -I, -perp(b)],
  dF = K2 dr/dq + C2 drdot/dq (+ the cage terms on theta_A, theta_B), and
  Q = (F, a x F, -F, -b x F), dQ/dq with the arms turning with their bodies.
* ``planar_velocity_rows`` (one thread per mounting, for driven runs): dQ/dv from C2 and the
  cage-rate sensitivities, dF/dv = C2 dr/dq (+ the cage-rate terms on omega_A, omega_B) mapped
  as dQ/dq (the arms do not depend on velocities); :meth:`TaperedPlanarRows.launch_velocity`.
"""
import functools

import warp as wp

from .tapered_rollers_ref import N_Q


@functools.lru_cache(maxsize=None)
def kernels(dtype):
    """(planar_state, planar_rows) for ``dtype``."""

    @wp.func
    def arm(pose: wp.array2d(dtype=dtype), body: int, cx: dtype, cy: dtype):
        th = pose[body, 2]
        c = wp.cos(th)
        s = wp.sin(th)
        return c * cx - s * cy, s * cx + c * cy

    @wp.kernel(module="unique")
    def planar_state(
        # Model:
        bodies: wp.array2d(dtype=wp.int32),
        centres: wp.array2d(dtype=dtype),
        owner: wp.array(dtype=wp.int32),
        phase: wp.array(dtype=dtype),
        gamma: wp.array(dtype=dtype),
        # Data in:
        pose: wp.array2d(dtype=dtype),
        vel: wp.array2d(dtype=dtype),
        # Data out:
        q: wp.array2d(dtype=dtype),
        qdot: wp.array2d(dtype=dtype),
        psi: wp.array(dtype=dtype),
        psidot: wp.array(dtype=dtype),
    ):
        j = wp.tid()
        k = owner[j]
        A = bodies[k, 0]
        B = bodies[k, 1]
        ax, ay = arm(pose, A, centres[k, 0], centres[k, 1])
        bx, by = arm(pose, B, centres[k, 2], centres[k, 3])
        for c in range(N_Q):
            q[j, c] = dtype(0.0)
            qdot[j, c] = dtype(0.0)
        q[j, 0] = (pose[A, 0] + ax) - (pose[B, 0] + bx)
        q[j, 1] = (pose[A, 1] + ay) - (pose[B, 1] + by)
        # perp(v) = (-v_y, v_x)
        qdot[j, 0] = (vel[A, 0] + vel[A, 2] * (-ay)) - (vel[B, 0] + vel[B, 2] * (-by))
        qdot[j, 1] = (vel[A, 1] + vel[A, 2] * ax) - (vel[B, 1] + vel[B, 2] * bx)
        g = gamma[j]
        h = dtype(0.5)
        psi[j] = phase[j] + h * ((dtype(1.0) - g) * pose[A, 2] + (dtype(1.0) + g) * pose[B, 2])
        psidot[j] = h * ((dtype(1.0) - g) * vel[A, 2] + (dtype(1.0) + g) * vel[B, 2])

    @wp.kernel(module="unique")
    def planar_rows(
        # Model:
        bodies: wp.array2d(dtype=wp.int32),
        centres: wp.array2d(dtype=dtype),
        first: wp.array(dtype=wp.int32),
        count: wp.array(dtype=wp.int32),
        gamma: wp.array(dtype=dtype),
        # Data in:
        pose: wp.array2d(dtype=dtype),
        vel: wp.array2d(dtype=dtype),
        f: wp.array2d(dtype=dtype),
        dfdq: wp.array3d(dtype=dtype),
        dfdv: wp.array3d(dtype=dtype),
        dfdpsi: wp.array2d(dtype=dtype),
        # Data out:
        Q: wp.array2d(dtype=dtype),
        dQ: wp.array3d(dtype=dtype),
    ):
        k = wp.tid()
        A = bodies[k, 0]
        B = bodies[k, 1]
        ax, ay = arm(pose, A, centres[k, 0], centres[k, 1])
        bx, by = arm(pose, B, centres[k, 2], centres[k, 3])
        F = wp.vector(dtype(0.0), dtype(0.0), length=2, dtype=dtype)
        K2 = wp.matrix(dtype(0.0), dtype(0.0), dtype(0.0), dtype(0.0), shape=(2, 2), dtype=dtype)
        C2 = wp.matrix(dtype(0.0), dtype(0.0), dtype(0.0), dtype(0.0), shape=(2, 2), dtype=dtype)
        FpA = wp.vector(dtype(0.0), dtype(0.0), length=2, dtype=dtype)
        FpB = wp.vector(dtype(0.0), dtype(0.0), length=2, dtype=dtype)
        h = dtype(0.5)
        for jj in range(count[k]):
            j = first[k] + jj
            wa = h * (dtype(1.0) - gamma[j])
            wb = h * (dtype(1.0) + gamma[j])
            for a in range(2):
                F[a] = F[a] + f[j, a]
                FpA[a] = FpA[a] + dfdpsi[j, a] * wa
                FpB[a] = FpB[a] + dfdpsi[j, a] * wb
                for b in range(2):
                    K2[a, b] = K2[a, b] + dfdq[j, a, b]
                    C2[a, b] = C2[a, b] + dfdv[j, a, b]
        # dF (2 x 6) over (x_A, y_A, th_A, x_B, y_B, th_B)
        wA = vel[A, 2]
        wB = vel[B, 2]
        for a in range(2):
            d0 = K2[a, 0]
            d1 = K2[a, 1]
            # dr/dth_A = perp(a) = (-a_y, a_x); drdot/dth_A = -w_A a; drdot/dth_B = w_B b
            d2 = K2[a, 0] * (-ay) + K2[a, 1] * ax + (C2[a, 0] * (-wA * ax) + C2[a, 1] * (-wA * ay)) + FpA[a]
            d5 = K2[a, 0] * by + K2[a, 1] * (-bx) + (C2[a, 0] * (wB * bx) + C2[a, 1] * (wB * by)) + FpB[a]
            dQ[k, a, 0] = d0
            dQ[k, a, 1] = d1
            dQ[k, a, 2] = d2
            dQ[k, a, 3] = -d0
            dQ[k, a, 4] = -d1
            dQ[k, a, 5] = d5
            dQ[k, 3 + a, 0] = -d0
            dQ[k, 3 + a, 1] = -d1
            dQ[k, 3 + a, 2] = -d2
            dQ[k, 3 + a, 3] = d0
            dQ[k, 3 + a, 4] = d1
            dQ[k, 3 + a, 5] = -d5
        for c in range(6):
            dQ[k, 2, c] = ax * dQ[k, 1, c] - ay * dQ[k, 0, c]
            dQ[k, 5, c] = -(bx * dQ[k, 1, c] - by * dQ[k, 0, c])
        # the arms turn with their bodies: d(a x F)/d theta_A = perp(a) x F
        dQ[k, 2, 2] = dQ[k, 2, 2] + ((-ay) * F[1] - ax * F[0])
        dQ[k, 5, 5] = dQ[k, 5, 5] - ((-by) * F[1] - bx * F[0])
        Q[k, 0] = F[0]
        Q[k, 1] = F[1]
        Q[k, 2] = ax * F[1] - ay * F[0]
        Q[k, 3] = -F[0]
        Q[k, 4] = -F[1]
        Q[k, 5] = -(bx * F[1] - by * F[0])

    return planar_state, planar_rows


@functools.lru_cache(maxsize=None)
def velocity_kernel(dtype):
    """``planar_velocity_rows`` for ``dtype`` (module docstring; reference: the dQ/dv of
    :meth:`rvtool.bearings.tapered_set.TaperedBearingSet.raw`)."""

    @wp.kernel(module="unique")
    def planar_velocity_rows(
        # Model:
        bodies: wp.array2d(dtype=wp.int32),
        centres: wp.array2d(dtype=dtype),
        first: wp.array(dtype=wp.int32),
        count: wp.array(dtype=wp.int32),
        gamma: wp.array(dtype=dtype),
        # Data in:
        pose: wp.array2d(dtype=dtype),
        dfdv: wp.array3d(dtype=dtype),
        dfdpsidot: wp.array2d(dtype=dtype),
        # Data out:
        dQv: wp.array3d(dtype=dtype),
    ):
        k = wp.tid()
        A = bodies[k, 0]
        B = bodies[k, 1]
        th = pose[A, 2]
        ax = wp.cos(th) * centres[k, 0] - wp.sin(th) * centres[k, 1]
        ay = wp.sin(th) * centres[k, 0] + wp.cos(th) * centres[k, 1]
        th = pose[B, 2]
        bx = wp.cos(th) * centres[k, 2] - wp.sin(th) * centres[k, 3]
        by = wp.sin(th) * centres[k, 2] + wp.cos(th) * centres[k, 3]
        C2 = wp.matrix(dtype(0.0), dtype(0.0), dtype(0.0), dtype(0.0), shape=(2, 2), dtype=dtype)
        FdA = wp.vector(dtype(0.0), dtype(0.0), length=2, dtype=dtype)
        FdB = wp.vector(dtype(0.0), dtype(0.0), length=2, dtype=dtype)
        h = dtype(0.5)
        for jj in range(count[k]):
            j = first[k] + jj
            wa = h * (dtype(1.0) - gamma[j])
            wb = h * (dtype(1.0) + gamma[j])
            for a in range(2):
                FdA[a] = FdA[a] + dfdpsidot[j, a] * wa
                FdB[a] = FdB[a] + dfdpsidot[j, a] * wb
                for b in range(2):
                    C2[a, b] = C2[a, b] + dfdv[j, a, b]
        for a in range(2):
            d0 = C2[a, 0]
            d1 = C2[a, 1]
            d2 = C2[a, 0] * (-ay) + C2[a, 1] * ax + FdA[a]
            d5 = C2[a, 0] * by + C2[a, 1] * (-bx) + FdB[a]
            dQv[k, a, 0] = d0
            dQv[k, a, 1] = d1
            dQv[k, a, 2] = d2
            dQv[k, a, 3] = -d0
            dQv[k, a, 4] = -d1
            dQv[k, a, 5] = d5
            dQv[k, 3 + a, 0] = -d0
            dQv[k, 3 + a, 1] = -d1
            dQv[k, 3 + a, 2] = -d2
            dQv[k, 3 + a, 3] = d0
            dQv[k, 3 + a, 4] = d1
            dQv[k, 3 + a, 5] = -d5
        for c in range(6):
            dQv[k, 2, c] = ax * dQv[k, 1, c] - ay * dQv[k, 0, c]
            dQv[k, 5, c] = -(bx * dQv[k, 1, c] - by * dQv[k, 0, c])

    return planar_velocity_rows


class TaperedPlanarRows:
    """The planar rows of a tapered set on the device: ``rollers`` its
    :class:`~warp_contacts.tapered_rollers.TaperedRollerKernel`; bodies (M, 2) pose rows of the
    inner and outer body (the ground: the pose array's last row), centres (M, 4) the inner and
    outer ring centres in their bodies [m], owner (R,), phase (R,) [rad], gamma (R,) per roller
    (rollers contiguous per mounting). :meth:`rows` takes host poses/velocities (nb, 3) and
    returns device arrays Q (M, 6), dQ/dq (M, 6, 6) (overwritten by the next call); :meth:`launch`
    reads the device arrays ``pose``, ``vel`` ((nb + 1, 3), the ground's row last) as they are."""

    def __init__(self, rollers, bodies, centres, owner, phase, gamma, n_bodies):
        import numpy as np
        self.rollers, self.device = rollers, rollers.device
        dt, nd, d = rollers.wdtype, rollers.ndtype, rollers.device
        owner = np.asarray(owner, np.int64)
        M, R = len(bodies), len(owner)
        if np.any(np.diff(owner) < 0):
            raise ValueError("the rollers of a mounting must be contiguous")
        first = np.searchsorted(owner, np.arange(M)).astype(np.int32)
        count = np.bincount(owner, minlength=M).astype(np.int32)
        arr = lambda a, t, n=None: wp.array(np.ascontiguousarray(a, n), dtype=t, device=d)
        self.bodies = arr(bodies, wp.int32, np.int32)
        self.centres = arr(np.asarray(centres).reshape(M, 4), dt, nd)
        self.owner = arr(owner, wp.int32, np.int32)
        self.phase, self.gamma = arr(phase, dt, nd), arr(gamma, dt, nd)
        self.first, self.count = arr(first, wp.int32), arr(count, wp.int32)
        self.pose = wp.zeros((n_bodies + 1, 3), dtype=dt, device=d)
        self.vel = wp.zeros((n_bodies + 1, 3), dtype=dt, device=d)
        self._host = (np.zeros((n_bodies + 1, 3), nd), np.zeros((n_bodies + 1, 3), nd))
        self.Q = wp.zeros((M, 6), dtype=dt, device=d)
        self.dQ = wp.zeros((M, 6, 6), dtype=dt, device=d)
        self.state_kernel, self.rows_kernel = kernels(dt)
        self.M, self.R = M, R
        self.dQv = None                               # dQ/dv (M, 6, 6): allocated by the first launch_velocity
        dev = rollers.device_array
        self._state_cmd = wp.launch(self.state_kernel, dim=R, device=d,
                                    inputs=[self.bodies, self.centres, self.owner, self.phase, self.gamma, self.pose,
                                            self.vel],
                                    outputs=[dev("q"), dev("qdot"), dev("psi"), dev("psidot")], record_cmd=True)
        self._rows_cmd = wp.launch(self.rows_kernel, dim=M, device=d,
                                   inputs=[self.bodies, self.centres, self.first, self.count, self.gamma, self.pose,
                                           self.vel, dev("f"), dev("dfdq"), dev("dfdv"), dev("dfdpsi")],
                                   outputs=[self.Q, self.dQ], record_cmd=True)

    def rows(self, pose, vel=None):
        hp, hv = self._host
        hp[:-1] = pose
        hv[:-1] = 0.0 if vel is None else vel
        self.pose.assign(hp)
        self.vel.assign(hv)
        return self.launch()

    def launch(self):
        """:meth:`rows` at the poses/velocities in the device arrays ``pose``, ``vel`` as they are
        (written on the device by the caller; no transfer)."""
        self._state_cmd.launch()
        self.rollers.launch()
        self._rows_cmd.launch()
        return self.Q, self.dQ

    def launch_velocity(self):
        """:meth:`launch` and dQ/dv: (Q (M, 6), dQ/dq, dQ/dv (M, 6, 6)) device arrays (driven runs)."""
        if self.dQv is None:
            dev = self.rollers.device_array
            self.dQv = wp.zeros((self.M, 6, 6), dtype=self.rollers.wdtype, device=self.device)
            self._vel_cmd = wp.launch(velocity_kernel(self.rollers.wdtype), dim=self.M, device=self.device,
                                      inputs=[self.bodies, self.centres, self.first, self.count, self.gamma,
                                              self.pose, dev("dfdv"), dev("dfdpsidot")],
                                      outputs=[self.dQv], record_cmd=True)
        self.launch()
        self._vel_cmd.launch()
        return self.Q, self.dQ, self.dQv


__all__ = ["TaperedPlanarRows", "kernels", "velocity_kernel"]
