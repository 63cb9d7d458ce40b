"""Rolling-element rows between a ring body with retained axial and tilt coordinates and its
housing: the spatial state of an output flange on its main-bearing rows (issue 32).

Each ball row (a :class:`~rvtool.bearings.spec.BallBearing` or the two rows of an
:class:`~rvtool.bearings.spec.AngularContactPair`) or roller row (a
:class:`~rvtool.bearings.spec.CrossedRollerBearing`, rollers alternating +-alpha, or a radial
cylindrical / needle row, alpha = 0; sliced into laminae along each roller) sits between an inner-ring body A and an
outer-ring body B (``GROUND`` allowed). Beside its planar coordinates (x, y, theta) a body may
retain its out-of-plane coordinates (z, gamma_x, gamma_y): the axial translation and the two
small tilts about the mounting's axial centre. They are carried as one more pose row of the
evaluator (``tilt_bodies`` maps a planar body to the row holding its (z, gamma_x, gamma_y));
a body without one holds them at zero.

Ball kinematics (Jones 1960, "A general theory for elastically constrained ball and radial roller
bearings under arbitrary load and speed conditions", J. Basic Eng. 82; Harris & Kotzalas, Advanced
Concepts of Bearing Technology, 5th ed. (2007), ch. 1, "distributed load ... under combined radial,
axial and moment loading"): ball j of row k at azimuth psi_j (the planar cage kinematics of
:mod:`warp_contacts.rolling_elements_ref`), pitch radius rho = d_m / 2 and axial station z_k sees
the relative displacement of the inner ring at its centre rho u + z_k e_z,

    delta_r = (c_A - c_B) . u + z_k (gamma_y cos psi - gamma_x sin psi),
    delta_a = (z_A - z_B) + rho (gamma_x sin psi - gamma_y cos psi),

(gamma the tilt of A relative to B, small angles). The groove-centre distance then is
a = (A cos alpha_0 + delta_r, A sin alpha_0 + s_k + sigma_k delta_a) with s_k the row's axial
approach at zero external load (:attr:`AngularContactPair.axial_offsets`: the preload, end play or
interference) and sigma_k its axial sense; the approach delta = |a| - A - c and the working contact
angle alpha_w = atan2(a_z, a_r) follow from the displacement, F = K(alpha_w) <delta>^(3/2)
(Eq. (ball_bearing), K of the kernels' law with the race curvatures of the working angle). The force
on A is f_u u + f_z e_z with f_u = -F cos(alpha_w), f_z = -sigma_k F sin(alpha_w), acting at
rho u + z_k e_z: on A's planar coordinates the planar element's generalized forces, on its
out-of-plane coordinates (f_z, m sin psi, -m cos psi) with m = rho f_z - z_k f_u (Eq.
(width_resultant)); B receives the opposite. The same point enters the kinematics and the moment,
so the tangent is the Hessian of the balls' potential (symmetric at fixed cage).

A roller lamina at its centre (rho_l, z_l) (along the roller's generator, as the planar packing
places it) has the fixed contact normal (cos alpha u, sigma sin alpha e_z): its approach is
delta = delta_r cos(alpha) + sigma delta_a sin(alpha) - c - crown and F = k <delta>^p (Eq.
(normal_force)); a tilt thus loads a crossed-roller row's +alpha and -alpha rollers on opposite
sides, and a radial row's laminae along their length (the roller's own tilting moment).

At zero axial and tilt displacement the in-plane forces are those of the planar element
(:class:`~rvtool.bearings.set.BearingSet`), term by term. Damping of the balls is not carried in the
spatial use (a named error): the quasi-static protocols need none.

Tangent: forward mode over the 12 unit seeds (planar and out-of-plane coordinates of A and B),
analytic; tests check it against central differences.

Backends: "numpy" (:meth:`SpatialBearingSet.balls`, the readable reference) or "warp" (the kernel of
:mod:`warp_contacts.spatial_balls`, one thread per element; its rows reach the merged element's
device sums like a planar family's, :mod:`warp_contacts.segment_sum`).
"""
from functools import lru_cache

import numpy as np

from warp_contacts import rolling_elements_ref as ref
from warp_contacts.circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY

from ..contact.circle_set import GROUND
from ..contact.evaluator import Evaluation, StagedLaunch, all_finite
from ..errors import RvtoolInputError
from .set import BearingLoads, Mounting, NoHistory, pack_mounting
from warp_contacts import laws_ref

from .spec import AngularContactPair, BallBearing, CylindricalRollerBearing
from ..validation import check_body_state, SPATIAL_LAYOUT

#: bearings whose rows resolve the spatial state
SPATIAL_TYPES = (BallBearing, AngularContactPair, CylindricalRollerBearing)

#: coordinates of one ball's seeds: A (x, y, theta), A (z, gamma_x, gamma_y), B (x, y, theta), B (z, ...)
N_BALL_COORDS = 12


def _perp(v):
    return np.column_stack([-v[:, 1], v[:, 0]])


def _cross(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _rot(theta, xi):
    c, s = np.cos(theta), np.sin(theta)
    return np.column_stack([c * xi[:, 0] - s * xi[:, 1], s * xi[:, 0] + c * xi[:, 1]])


def ball_law_spatial(ar, az, fp):
    """Eq. (ball_bearing) at groove-centre distance components (a_r, a_z) (N,) [m].

    Returns (delta, F, alpha_w, Fr, Fa, dFr/da_r, dFr/da_z, dFa/da_r, dFa/da_z) with Fr = F cos(alpha_w),
    Fa = F sin(alpha_w) [N]; K(alpha_w) from :func:`warp_contacts.rolling_elements_ref.ball_stiffness`
    times the row's factor s_K (exact at the free contact angle)."""
    A = fp[:, ref.R_A]
    L = np.sqrt(ar * ar + az * az)
    Ls = np.where(L > 0, L, 1.0)
    delta = L - A - fp[:, ref.R_CLEAR]
    on = delta > 0
    dp = np.where(on, delta, 0.0)
    cw, sw = ar / Ls, az / Ls
    L3 = Ls ** 3
    cw_r, cw_z = az * az / L3, -ar * az / L3
    sw_r, sw_z = -ar * az / L3, ar * ar / L3
    K, dK = ref.ball_stiffness(cw, fp[:, ref.R_DBALL], fp[:, ref.R_PITCH], fp[:, ref.R_FI], fp[:, ref.R_FO],
                               fp[:, ref.R_EMOD])
    K, dK = fp[:, ref.R_KSCALE] * K, fp[:, ref.R_KSCALE] * dK
    F = np.where(on, K * dp ** 1.5, 0.0)
    root = np.sqrt(dp)
    F_r = np.where(on, dK * cw_r * dp ** 1.5 + 1.5 * K * root * cw, 0.0)
    F_z = np.where(on, dK * cw_z * dp ** 1.5 + 1.5 * K * root * sw, 0.0)
    return (delta, F, np.arctan2(az, ar), F * cw, F * sw, F_r * cw + F * cw_r, F_z * cw + F * cw_z,
            F_r * sw + F * sw_r, F_z * sw + F * sw_z)


def lamina_law_spatial(ar, az, fp):
    """A roller lamina at fixed contact angle alpha (crossed rollers +-alpha through sigma, radial
    rollers alpha = 0) at radial and signed axial displacement (a_r, a_z) = (delta_r, sigma delta_a)
    of its centre: delta = a_r cos(alpha) + a_z sin(alpha) - c - crown, F = k <delta>^p (Eq.
    (normal_force) without damping); the same outputs as :func:`ball_law_spatial`."""
    al = fp[:, ref.R_ALPHA]
    ca, sa = np.cos(al), np.sin(al)
    delta = ar * ca + az * sa - fp[:, ref.R_CLEAR] - fp[:, ref.R_CROWN]
    F, dF, _ = laws_ref.normal_force(fp[:, ref.R_K], fp[:, ref.R_P], 0.0, fp[:, ref.R_RAMP], delta, 0.0)
    return delta, F, al, F * ca, F * sa, dF * ca * ca, dF * ca * sa, dF * sa * ca, dF * sa * sa


class SpatialBearingSet(StagedLaunch):
    """Ball-bearing mountings whose rings retain axial and tilt coordinates (module docstring).

    mountings: :class:`~rvtool.bearings.set.Mounting` of a BallBearing or AngularContactPair;
    n_bodies: pose rows of the evaluator (planar bodies and out-of-plane rows together);
    tilt_bodies: {planar body index: pose row of its (z, gamma_x, gamma_y)}; a ring body not in it
    holds its out-of-plane coordinates. name: element name. backend "numpy" (default) or "warp",
    precision "float64" | "float32" (warp only), device "cpu" | "cuda:N". Follows the evaluator
    protocol of :class:`exudyn_user_elements.contact_element.ContactElement`.
    """

    def __init__(self, mountings, n_bodies, tilt_bodies, *, name="bearings", backend="numpy", precision="float64",
                 device="cpu"):
        if isinstance(n_bodies, bool) or not isinstance(n_bodies, (int, np.integer)) or n_bodies < 1:
            raise RvtoolInputError(f"n_bodies = {n_bodies!r} is outside the valid range [1, inf)")
        if len(mountings) == 0:
            raise RvtoolInputError("mountings must contain at least one Mounting (got 0)")
        self.name, self.n_bodies = name, int(n_bodies)
        self.mountings = tuple(mountings)
        self.tilt_bodies = dict(tilt_bodies)
        for body, row in self.tilt_bodies.items():
            for nm, v in (("body", body), ("row", row)):
                if not (isinstance(v, (int, np.integer)) and 0 <= v < n_bodies):
                    raise RvtoolInputError(f"tilt_bodies {nm} {v!r} is outside the valid range [0, {n_bodies - 1}]")
        self.history = NoHistory()
        fp, ids, cols, rho, z, row_of, owner, kinds = [], [], [], [], [], [], [], []
        g = n_bodies                                    # the ground slot (dropped on assembly)
        for k, m in enumerate(self.mountings):
            if not isinstance(m, Mounting) or not isinstance(m.bearing, SPATIAL_TYPES):
                raise RvtoolInputError(f"mountings[{k}] must be a Mounting of a BallBearing, AngularContactPair or "
                                       f"roller bearing (crossed, cylindrical, needle); got "
                                       f"{type(getattr(m, 'bearing', m)).__name__}")
            rows = m.bearing.rows if isinstance(m.bearing, AngularContactPair) else (m.bearing,)
            for r, row in enumerate(rows):
                if row.damping != 0:
                    raise RvtoolInputError(f"{m.name}: rows[{r}].damping = {row.damping} N s/m; valid with a spatial "
                                           "flange: 0 (element damping is not carried in the spatial use)")
            for nm in ("inner", "outer"):
                b = getattr(m, nm)
                if not (b == GROUND or (isinstance(b, (int, np.integer)) and 0 <= b < n_bodies)):
                    raise RvtoolInputError(f"mountings[{k}].{nm} = {b!r} is outside the valid range "
                                           f"[0, {n_bodies - 1}] or GROUND (-1)")
            prow, r_kind, rid, r_rho, r_z, r_row = pack_mounting(m)
            kinds += r_kind
            slot = [g if m.inner == GROUND else m.inner, self.tilt_bodies.get(m.inner, g),
                    g if m.outer == GROUND else m.outer, self.tilt_bodies.get(m.outer, g)]
            idx = np.concatenate([3 * s + np.arange(3) for s in slot])
            fp += prow
            ids += rid
            cols += [idx] * len(prow)
            rho += r_rho
            z += r_z
            row_of += r_row
            owner += [k] * len(prow)
        self.fparams = np.array(fp)
        self.ids = tuple(ids)
        self.columns = np.array(cols)                  # (N, 12) pose-vector indices of each ball's seeds
        self.element_radius, self.element_station = np.array(rho), np.array(z)
        self.element_row, self.owner = np.array(row_of), np.array(owner)
        self.kind = np.array(kinds)
        self._ball = self.kind == ref.KIND_BALL
        self._all_ball, self._any_ball = bool(np.all(self._ball)), bool(np.any(self._ball))
        # the per-ball constants of :meth:`balls` (row parameters and seed rows), formed once
        fp = self.fparams
        self._xi = (fp[:, ref.R_XI_A:ref.R_XI_A + 2], fp[:, ref.R_XI_B:ref.R_XI_B + 2])
        self._g, self._sig = fp[:, ref.R_GAMMA], fp[:, ref.R_SIGMA]
        A, al0 = fp[:, ref.R_A], fp[:, ref.R_ALPHA]
        self._ar0 = np.where(self._ball, A * np.cos(al0), 0.0)
        self._az0 = np.where(self._ball, A * np.sin(al0) + fp[:, ref.R_SAX], 0.0)
        self._n = 3 * (n_bodies + 1)
        # the seeds that move some ball (a grounded outer ring without tilt rows has none: the tangent
        # is formed over the live seeds only, half of them for a flange on a rigid housing)
        ground = 3 * n_bodies + np.arange(3)
        self._live = np.flatnonzero(~np.all(np.isin(self.columns, ground), axis=0))
        self._seeds = np.eye(N_BALL_COORDS)[:, self._live]
        # scatter of the per-ball rows into the assembled vector and matrix (np.bincount)
        self._flat_q = self.columns.ravel()
        self._flat_k = (self.columns[:, :, None] * self._n + self.columns[:, None, self._live]).ravel()
        if backend not in ("numpy", "warp"):
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are ['numpy', 'warp']")
        if backend == "numpy" and precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")
        self.backend, self.precision = backend, precision
        self.launches = 0
        self._staged = None
        if backend == "warp":
            from warp_contacts import spatial_balls as sb
            self._flat_k12 = (self.columns[:, :, None] * self._n + self.columns[:, None, :]).ravel()
            ip = np.zeros((len(fp), sb.N_INT), np.int32)
            ip[:, [sb.S_A, sb.S_TA, sb.S_B, sb.S_TB]] = self.columns[:, 0::3] // 3
            ip[:, sb.S_KIND] = self.kind
            geom = np.zeros((len(fp), sb.N_GEOM))
            geom[:, sb.G_RHO], geom[:, sb.G_Z] = self.element_radius, self.element_station
            geom[:, sb.G_AR0], geom[:, sb.G_AZ0] = self._ar0, self._az0
            self._kernel = sb.SpatialBallKernel(fp, geom, ip, n_bodies, precision, device)

    # -- per ball ----------------------------------------------------------------
    def balls(self, pose, vel=None):
        """Per-ball results at poses (n_bodies, 3): (Q (N, 12), dQ/dq (N, 12, L) over the L live seeds
        (``self._live``: the ball's 12 coordinates less those held by the ground), obs (N, 8), aux (N, 4):
        f_u, f_z [N] on A, working angle alpha_w [rad], moment arm m [N m])."""
        p = np.zeros(3 * self.n_bodies + 3)
        p[:-3] = np.ravel(np.asarray(pose, float))
        x = p[self.columns]                             # (N, 12)
        fp = self.fparams
        N = len(fp)
        xiA, xiB = self._xi
        a, b = _rot(x[:, 2], xiA), _rot(x[:, 8], xiB)
        g = self._g
        psi = fp[:, ref.R_PSI0] + 0.5 * ((1 - g) * x[:, 2] + (1 + g) * x[:, 8])
        c, s = np.cos(psi), np.sin(psi)
        u = np.column_stack([c, s])
        pu = _perp(u)
        d = x[:, 0:2] + a - x[:, 6:8] - b
        zr, gx, gy = x[:, 3] - x[:, 9], x[:, 4] - x[:, 10], x[:, 5] - x[:, 11]
        rho, zk, sig = self.element_radius, self.element_station, self._sig
        dr = (d[:, 0] * u[:, 0] + d[:, 1] * u[:, 1]) + zk * (gy * c - gx * s)
        da = zr + rho * (gx * s - gy * c)
        ball = self._ball
        ar = self._ar0 + dr
        az = self._az0 + sig * da
        if self._all_ball:
            law = ball_law_spatial(ar, az, fp)
        else:
            law = np.zeros((9, N))
            if self._any_ball:
                law[:, ball] = ball_law_spatial(ar[ball], az[ball], fp[ball])
            law[:, ~ball] = lamina_law_spatial(ar[~ball], az[~ball], fp[~ball])
        delta, F, alw, Fr, Fa, Fr_r, Fr_z, Fa_r, Fa_z = law
        fu, fz = -Fr, -sig * Fa
        m = rho * fz - zk * fu
        fA = fu[:, None] * u
        Q = np.empty((N, N_BALL_COORDS))
        Q[:, 0:2], Q[:, 2] = fA, _cross(a, fA)
        Q[:, 3], Q[:, 4], Q[:, 5] = fz, m * s, -m * c
        Q[:, 6:8], Q[:, 8] = -fA, -_cross(b, fA)
        Q[:, 9:12] = -Q[:, 3:6]
        # tangent: each intermediate's row of derivatives over the 12 seeds (forward mode, vectorized)
        E = self._seeds
        pa, pb = _perp(a), _perp(b)
        Jpsi = 0.5 * ((1 - g)[:, None] * E[2] + (1 + g)[:, None] * E[8])
        Jgx, Jgy = E[4] - E[10], E[5] - E[11]
        Jdd = (E[None, 0:2] + pa[:, :, None] * E[2] - E[None, 6:8] - pb[:, :, None] * E[8])      # (N, 2, 12)
        Jdr = (c[:, None] * Jdd[:, 0] + s[:, None] * Jdd[:, 1] + (np.sum(d * pu, axis=1) - zk * (gy * s + gx * c))[:, None] * Jpsi
               + zk[:, None] * (c[:, None] * Jgy - s[:, None] * Jgx))
        Jda = (E[3] - E[9]) + rho[:, None] * (s[:, None] * Jgx - c[:, None] * Jgy) + (rho * (gx * c + gy * s))[:, None] * Jpsi
        Jaz = sig[:, None] * Jda
        Jfu = -(Fr_r[:, None] * Jdr + Fr_z[:, None] * Jaz)
        Jfz = -sig[:, None] * (Fa_r[:, None] * Jdr + Fa_z[:, None] * Jaz)
        Jm = rho[:, None] * Jfz - zk[:, None] * Jfu
        JfA = u[:, :, None] * Jfu[:, None, :] + (fu[:, None] * pu)[:, :, None] * Jpsi[:, None, :]   # (N, 2, 12)
        dQ = np.empty((N, N_BALL_COORDS, len(self._live)))
        dQ[:, 0:2] = JfA
        dQ[:, 2] = _cross(pa, fA)[:, None] * E[2] + a[:, 0:1] * JfA[:, 1] - a[:, 1:2] * JfA[:, 0]
        dQ[:, 3] = Jfz
        dQ[:, 4] = Jm * s[:, None] + (m * c)[:, None] * Jpsi
        dQ[:, 5] = -Jm * c[:, None] + (m * s)[:, None] * Jpsi
        dQ[:, 6:8] = -JfA
        dQ[:, 8] = -(_cross(pb, fA)[:, None] * E[8] + b[:, 0:1] * JfA[:, 1] - b[:, 1:2] * JfA[:, 0])
        dQ[:, 9:12] = -dQ[:, 3:6]
        obs = np.zeros((N, N_OBS))
        obs[:, O_FN], obs[:, O_GAP] = F, -delta
        obs[:, O_PX:O_PY + 1] = x[:, 6:8] + b + rho[:, None] * u
        obs[:, O_NX:O_NY + 1] = u
        aux = np.column_stack([fu, fz, alw, m])
        return Q, dQ, obs, aux

    # -- evaluator protocol ------------------------------------------------------
    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"bearing set '{self.name}'", pose, vel, (self.n_bodies, 3), SPATIAL_LAYOUT)

    def evaluate(self, pose, vel=None, history=None, check=True):
        """Assembled :class:`Evaluation` at absolute poses (n_bodies, 3) (no history, no damping)."""
        if check:
            self.check_state(pose, vel)
        if self.backend == "warp":
            self.launches += 1      # the kernel's buffers change: launched evaluations read afresh
            Qb, dQb, obs, _ = self._kernel.evaluate(pose)
            return self._assembled(Qb, dQb, np.array(obs, float), self._flat_k12)
        Qb, dQb, obs, _ = self.balls(pose)
        return self._assembled(Qb, dQb, obs, self._flat_k)

    def _assembled(self, Qb, dQb, obs, flat_k):
        n = self._n
        Q = np.bincount(self._flat_q, weights=np.ravel(Qb), minlength=n)
        K = np.bincount(flat_k, weights=np.ravel(dQb), minlength=n * n).reshape(n, n)
        m = 3 * self.n_bodies
        return Evaluation(Q[:m], K[:m, :m], np.zeros((m, m)), obs, (), all_finite(Q, K))

    # -- rows summed on the device (the merged element: warp_contacts.segment_sum), backend "warp" ----
    velocity_rows = False
    """No damping in the spatial use: no velocity tangent rows."""

    stages_velocity = False
    """The kernel reads poses only."""

    def row_buffers(self):
        """(index (N, 12) element coordinate of every row entry, -1 for the ground; the Warp arrays q,
        dqdq that every launch overwrites; None: no velocity tangent)."""
        k = self._kernel
        m = 3 * self.n_bodies
        return np.where(self.columns < m, self.columns, -1), k.device_array("q"), k.device_array("dqdq"), None

    def launched_field(self, name):
        """Field ``name`` of :class:`Evaluation` from the outputs of the last launch."""
        r = self._staged.read
        if name in ("Q", "dQdq", "dQdv", "finite"):
            ev = self._assembled(r("q"), r("dqdq"), None, self._flat_k12)
            return ev.finite if name == "finite" else getattr(ev, name)
        if name == "obs":
            return np.array(r("obs"), float)
        return ()

    def commit(self, pose, vel=None, evaluation=None):
        """Observations (N, 8) at the accepted state (nothing to commit)."""
        return np.array(evaluation.obs if evaluation is not None else self.balls(pose)[2], float)

    def resultants(self, pose, vel=None):
        """{mounting name: :class:`~rvtool.bearings.set.BearingLoads`} on the inner rings about the
        mounting centres: force (2,), axial_force, tilting_moment (M_x, M_y) -- fed back to the
        bodies here -- and the axial force of each row [N]."""
        _, _, obs, aux = self.balls(pose)
        u = obs[:, O_NX:O_NY + 1]
        fu, fz, m = aux[:, 0], aux[:, 1], aux[:, 3]
        out = {}
        for k, mt in enumerate(self.mountings):
            sel = self.owner == k
            rows = self.element_row[sel]
            n_rows = 2 if isinstance(mt.bearing, AngularContactPair) else 1   # rollers: one row
            out[mt.name] = BearingLoads(
                force=np.sum(fu[sel, None] * u[sel], axis=0), axial_force=float(np.sum(fz[sel])),
                tilting_moment=np.sum(m[sel, None] * np.column_stack([u[sel, 1], -u[sel, 0]]), axis=0),
                row_axial_forces=tuple(float(np.sum(fz[sel][rows == r])) for r in range(n_rows)))
        return out

    def working_angles(self, pose):
        """{mounting name: working contact angle of each ball [rad]} (element order as in the ids)."""
        alw = self.balls(pose)[3][:, 2]
        return {m.name: alw[self.owner == k] for k, m in enumerate(self.mountings)}

    def element_loads(self, obs):
        """{mounting name: normal force of each rolling element [N]} from observations (N, 8): balls as
        they are, rollers summed over their laminae (element order as in the ids)."""
        fn = np.asarray(obs)[:, O_FN]
        out = {}
        for k, m in enumerate(self.mountings):
            f, b = fn[self.owner == k], m.bearing
            out[m.name] = f.reshape(b.n_rollers, b.n_slices).sum(axis=1) if isinstance(b, CylindricalRollerBearing) else f
        return out


def flange_wrench(pair, q):
    """Wrench on a flange (the inner rings) on ``pair`` (any bearing of :data:`SPATIAL_TYPES`) against a rigid housing at relative
    displacement q = (delta_x, delta_y, delta_z [m], gamma_x, gamma_y [rad]) of its mounting centre:
    (w (5,) = (F_x, F_y, F_z [N], M_x, M_y [N m]) on the flange, its tangent dw/dq (5, 5), row axial
    forces (n_rows,) [N]). The cage is at its built phase."""
    s = flange_set(pair)
    pose = np.array([[q[0], q[1], 0.0], [q[2], q[3], q[4]]], float)
    ev = s.evaluate(pose)
    sel = [0, 1, 3, 4, 5]
    loads = s.resultants(pose)["flange"]
    return ev.Q[sel], ev.dQdq[np.ix_(sel, sel)], np.array(loads.row_axial_forces)


@lru_cache(maxsize=32)
def flange_set(pair):
    """The one-mounting set of a flange (body 0) and its out-of-plane row (1) on ``pair``, housing ground."""
    return SpatialBearingSet([Mounting(name="flange", bearing=pair, inner=0, outer=GROUND)], 2, {0: 1}, name="flange")
