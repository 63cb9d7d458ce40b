"""Spring control: equilibria with the output driven through a torsional spring to target
angles, continuous through the free play (used for lost motion).

Lost motion is the output-angle difference between the equilibria at +f and -f output
torque (f = 3 % of T_rated). Under torque (load) control the equilibria inside the free
play (output-pin backlash, pin clearance) are held only by the weak regularization
springs, and a Newton step there can jump or stall (:class:`Continuation` failed on 5-6 %
of the Monte Carlo variants). Here the flange rotation is driven instead through a
torsional spring of stiffness k_s to a target angle phi: the output torque carried by the
spring,

    T(phi) = k_s (phi - theta_out(phi)),

is continuous and increasing in phi (dT/dphi = k_s K / (K + k_s) > 0 with K >= the
regularization stiffness), every equilibrium is held by the spring, and phi is marched
through the free play in adaptive steps and refined by regula falsi (Illinois) until
|T - level| <= ``torque_tol``. The equilibrium at T(phi) = level is the equilibrium of
load control at that torque: the applied torque and the spring torque enter the flange
rotation equation identically (Eq. (contact_mapping) plus the load).

The spring is the flange's rotational regularization spring with stiffness k_reg + k_s and
the stiffness-weighted offset (k_reg phi_reg + k_s phi) / (k_reg + k_s): two parallel
linear springs are exactly one, so nothing is added to the Exudyn system and the
regularization acts as in load control.

dT/dphi > 0 holds where the reducer's tangent stiffness K about the flange stays above -k_s.
In the free play the wheels float in their pin and bearing clearances, and where the output
pins change flanks the torque--angle curve can fold back (K < 0: RD-40's Monte Carlo variant 0
folds at -0.06 N m, the flange then jumping by ~50 urad). A spring softer than the fold makes
T(phi) jump there (:class:`SnapThrough`; the load-controlled continuation stalls at the same
torque). The march then goes back to its last equilibrium before the jump and takes a stiffer
spring (x :data:`STIFFENING`, up to ``max_k_s``): the state is kept (phi moved so that the
stiffer spring carries the same torque), and the stiffer spring follows the curve through the
fold. The equilibria at the levels are the load-controlled ones whatever k_s (variant 0: the
lost motion agrees to 1e-10 arcmin between k_s = 1e6 and 1e7).
"""
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..validation import check_positive
from .continuation import Continuation
from .static import StaticSolver
from .stats import SolverStats

STIFFENING = 10.0
"""Factor of the control spring after a snap-through (:meth:`SpringControl.go_to`)."""


class SnapThrough(SolverFailure):
    """The spring-controlled torque jumps across the level between two targets closer than the
    march resolves: ``last`` = (phi, q) the last equilibrium before the jump."""

    def __init__(self, message, last):
        super().__init__(message)
        self.last = last


def output_rotation_spring(model):
    """(Exudyn object, stiffness [N m/rad]) of the regularization spring on the model's output rotation."""
    spring = model.regularization_spring(model.output)
    if spring is None:
        raise RvtoolInputError("the model has no rotational regularization spring on the output; build it with "
                               "regularization = (k_t, k_r) with k_r in (0, inf) N m/rad for spring-controlled lost motion")
    return spring


class SpringControl:
    """Equilibria of ``model`` at fixed input angle with the output rotation driven through a
    torsional spring k_s [N m/rad] to target angles phi [rad] (output displacement coordinate).

    max_step: largest phi step [rad] of the march; min_step: smallest before
    :class:`SolverFailure`; torque_tol: accepted |T - level| [N m]; abs_tol [N], rel_tol [-]: the
    equilibria's Newton tolerances (:class:`StaticSolver`'s defaults); max_k_s: the stiffest control
    spring a snap-through may call for [N m/rad] (module docstring; default 100 k_s, k_s: none).
    """

    def __init__(self, model, *, k_s, input_angle=0.0, start_torque=0.0, max_step=2e-4, min_step=1e-8,
                 torque_tol=None, abs_tol=1e-6, rel_tol=1e-9, max_k_s=None):
        check_positive("k_s", k_s)
        check_positive("max_step", max_step)
        check_positive("min_step", min_step)
        self.model = model
        self.k_s = float(k_s)
        self.max_k_s = 100.0 * self.k_s if max_k_s is None else float(max_k_s)
        if self.max_k_s < self.k_s:
            raise RvtoolInputError(f"max_k_s = {max_k_s!r} N m/rad is outside the valid range [k_s, inf) "
                                   f"(k_s = {self.k_s:g} N m/rad)")
        self.stiffenings = 0
        self.max_step, self.min_step = max_step, min_step
        self.torque_tol = torque_tol
        self.input_angle = input_angle
        self.obj, self.k_reg = output_rotation_spring(model)
        self.stats = SolverStats()
        self.static = StaticSolver(model, abs_tol=abs_tol, rel_tol=rel_tol)
        self.i_out = model.output_index
        self.phi_reg = float(model.mbs.GetObjectParameter(self.obj, "offset"))
        t0 = time.perf_counter()
        # The start is the load-controlled equilibrium at start_torque (Continuation's start:
        # a loaded state is regular, while a zero-load start inside the free play can converge
        # to a preloaded state off the branch the march then follows). Under the spring with
        # phi = theta + start_torque / k_s and no applied torque the same state is in equilibrium.
        cont = Continuation(model, input_angle=input_angle, initial_torque=float(start_torque), abs_tol=abs_tol,
                            rel_tol=rel_tol)
        model.set_output_torque(0.0)
        self.phi = float(cont.q[self.i_out] + start_torque / self.k_s)
        ok, q = self.solve_at(self.phi, cont.q)
        if not ok:
            self.restore()
            raise SolverFailure(f"no spring-controlled equilibrium at the start (output torque {start_torque:.6g} N m)")
        self.q = q
        self.stats.newton_iterations += cont.static.stats.newton_iterations
        self.stats.wall_s += time.perf_counter() - t0

    def _apply(self, phi):
        mbs, k, kr = self.model.mbs, self.k_s, self.k_reg
        mbs.SetObjectParameter(self.obj, "stiffness", kr + k)
        mbs.SetObjectParameter(self.obj, "offset", (kr * self.phi_reg + k * phi) / (kr + k))

    def restore(self):
        """The flange spring back to the regularization alone."""
        self.model.mbs.SetObjectParameter(self.obj, "stiffness", self.k_reg)
        self.model.mbs.SetObjectParameter(self.obj, "offset", self.phi_reg)

    def torque(self, q, phi):
        """Output torque [N m] carried by the control spring at state q and target phi."""
        return self.k_s * (phi - q[self.i_out])

    def solve_at(self, phi, q_start):
        """Warm-started equilibrium at target phi; (ok, q)."""
        self._apply(phi)
        s = self.static
        it0 = s.stats.newton_iterations
        ok, q = s.newton(q_start, ramp=False)
        ok = ok and s.plausible(q, self.input_angle)
        self.stats.solves += 1
        self.stats.newton_iterations += s.stats.newton_iterations - it0
        return ok, q

    def _reach(self, start, phi):
        """Equilibrium at target phi from the state ``start`` = (phi0, q0): warm-started solves
        in steps halved on failure (down to ``min_step``), then targets shifted by up to 1e-9 rad
        (Newton without line search can cycle on a contact-activation kink; the shifted target
        is a valid point of the same monotone curve). Returns (phi, q) or None."""
        cur_phi, cur_q = start
        step = phi - cur_phi
        while cur_phi != phi:
            nxt = phi if abs(phi - cur_phi) <= abs(step) else cur_phi + step
            ok, q = self.solve_at(nxt, cur_q)
            if ok:
                cur_phi, cur_q = nxt, q
                continue
            self.stats.rejected_steps += 1
            step *= 0.5
            if abs(step) < self.min_step:
                break
        else:
            return cur_phi, cur_q
        for d in (1e-11, -1e-11, 1e-10, -1e-10, 1e-9, -1e-9):
            ok, q = self.solve_at(phi + d, cur_q)
            if ok:
                return phi + d, q
        # last resort: the static solver's homotopy in the regularization stiffness from the
        # kinematic state at this target (where the output pins change flanks near zero torque
        # the warm-started Newton can cycle between activation patterns)
        self._apply(phi)
        ok, q = self.static.stiffened_start(self.input_angle)
        self.stats.solves += 1
        if ok:
            return phi, q
        return None

    def go_to(self, level):
        """Equilibrium at output torque ``level`` [N m]: march phi towards it in adaptive
        steps (halved on a failed Newton solve), then regula falsi on the bracket; after a
        snap-through, again from the last equilibrium before it with a stiffer spring (module
        docstring). Returns q."""
        t0 = time.perf_counter()
        while True:
            try:
                q = self._march(level)
                break
            except SnapThrough as exc:
                if self.k_s * STIFFENING > self.max_k_s * (1.0 + 1e-12):
                    raise SolverFailure(f"{exc} (control spring {self.k_s:g} N m/rad; max_k_s = "
                                        f"{self.max_k_s:g} N m/rad)") from None
                self.stiffen(*exc.last)
        self.stats.wall_s += time.perf_counter() - t0
        return q

    def stiffen(self, phi, q, factor=STIFFENING):
        """A ``factor`` stiffer control spring holding the equilibrium q (reached at target phi):
        the target moves to theta_out + T / k_s' so that the spring carries the same torque T."""
        T = self.torque(q, phi)
        self.k_s *= float(factor)
        self.phi, self.q = float(q[self.i_out] + T / self.k_s), q
        self._apply(self.phi)
        self.stiffenings += 1

    def _march(self, level):
        # 1e-7 of the level: 4e-7 N m on RD-40, i.e. ~1e-10 rad of flange angle at the engaged stiffness
        tol = self.torque_tol if self.torque_tol is not None else 1e-7 * max(abs(level), 1.0)
        T = self.torque(self.q, self.phi) - level
        sign = -np.sign(T)                       # direction of phi that moves T towards the level
        step = self.max_step
        a = (self.phi, self.q, T)                # last state on the starting side
        while abs(T) > tol and np.sign(T) != sign:
            got = self._reach((a[0], a[1]), a[0] + sign * step)
            if got is None:
                self._apply(a[0])
                raise SolverFailure(f"spring-controlled march stalled at phi = {a[0]:.9g} rad "
                                    f"(output torque {a[2] + level:.6g} N m, target {level:.6g} N m)")
            phi, q = got
            T = self.torque(q, phi) - level
            if np.sign(T) == sign or abs(T) <= tol:
                b = (phi, q, T)
                break
            a = (phi, q, T)
            step = min(2 * step, self.max_step)
        else:
            b = a
        if abs(b[2]) > tol:
            b = self._refine(a, b, tol, level)
        self.phi, self.q = b[0], b[1]
        self._apply(self.phi)
        return self.q

    def _refine(self, a, b, tol, level, max_iter=100):
        """Illinois regula falsi on T(phi) - level = 0 between a and b (opposite signs)."""
        fa_w, fb_w = a[2], b[2]
        side = 0
        for _ in range(max_iter):
            if abs(b[0] - a[0]) <= 1e-13 * max(1.0, abs(a[0])):
                # the bracket has closed on a point where T jumps across the level: the march
                # left its equilibrium branch there (a snap-through to another contact state)
                raise SnapThrough(f"the spring-controlled output torque jumps from {a[2] + level:.6g} to "
                                  f"{b[2] + level:.6g} N m at phi = {a[0]:.12g} rad without passing "
                                  f"{level:.6g} N m (snap-through between equilibrium branches)", (a[0], a[1]))
            phi = b[0] - fb_w * (b[0] - a[0]) / (fb_w - fa_w)
            near = b if abs(phi - b[0]) < abs(phi - a[0]) else a
            got = self._reach((near[0], near[1]), phi)
            if got is None:
                raise SolverFailure(f"no equilibrium at phi = {phi:.9g} rad inside the bracket "
                                    f"[{a[0]:.9g}, {b[0]:.9g}] rad")
            phi, q = got
            T = self.torque(q, phi) - level
            c = (phi, q, T)
            if abs(T) <= tol:
                return c
            if np.sign(T) == np.sign(b[2]):
                b, fb_w = c, T
                fa_w = fa_w * 0.5 if side == -1 else fa_w
                side = -1
            else:
                a, fa_w = c, T
                fb_w = fb_w * 0.5 if side == 1 else fb_w
                side = 1
        raise SolverFailure(f"regula falsi did not reach |T - level| <= {tol:.3g} N m in {max_iter} solves")
