"""A set of rolling-element bearings between planar bodies, evaluated in one
kernel launch; follows the evaluator protocol of the Exudyn contact element."""
import math
from dataclasses import dataclass

import numpy as np

from warp_contacts import rolling_elements_ref as ref

from ..contact.assembly import PairAssembler
from ..contact.circle_set import GROUND
from ..contact.evaluator import Evaluation, all_finite
from ..errors import RvtoolInputError
from .spec import AngularContactPair, BallBearing, CrossedRollerBearing, RollerBearing, roller_lamina_stiffness


@dataclass(frozen=True, kw_only=True)
class Mounting:
    """Where a bearing sits: inner ring on body ``inner`` at ``inner_centre`` and outer ring on
    body ``outer`` at ``outer_centre`` (body coordinates [m]); cage phase psi_0 [rad]."""
    name: str
    bearing: object
    inner: int
    outer: int
    inner_centre: tuple = (0.0, 0.0)
    outer_centre: tuple = (0.0, 0.0)
    cage_phase: float = 0.0


class NoHistory:
    """Rolling elements carry no contact memory."""


def _rows(m):
    """Packed rows (float (n, N_FLOAT), kind (n,), ids) of one mounted bearing."""
    b = m.bearing
    rows, kinds, ids = [], [], []

    def base(psi0, gamma, pitch):
        r = np.zeros(ref.N_FLOAT)
        r[ref.R_XI_A:ref.R_XI_A + 2] = m.inner_centre
        r[ref.R_XI_B:ref.R_XI_B + 2] = m.outer_centre
        r[ref.R_PSI0], r[ref.R_GAMMA], r[ref.R_PITCH] = psi0, gamma, pitch
        return r

    if isinstance(b, (RollerBearing, CrossedRollerBearing)):
        gamma = b.roller_diameter / b.pitch_diameter
        k = roller_lamina_stiffness(b.roller_length, b.n_slices)
        zs = (np.arange(b.n_slices) + 0.5) / b.n_slices * 2 - 1        # -1 ... 1 along the roller
        crown = (b.crowning if isinstance(b, RollerBearing) else 0.0) * zs ** 2
        for j in range(b.n_rollers):
            alpha = 0.0 if isinstance(b, RollerBearing) else (b.contact_angle if j % 2 == 0 else -b.contact_angle)
            for s in range(b.n_slices):
                r = base(m.cage_phase + 2 * math.pi * j / b.n_rollers, gamma, b.pitch_diameter)
                r[ref.R_K], r[ref.R_P], r[ref.R_ALPHA] = k, 10.0 / 9.0, alpha
                r[ref.R_CLEAR], r[ref.R_CROWN] = b.radial_clearance, crown[s]
                rows.append(r)
                kinds.append(ref.KIND_LAMINA)
                ids.append(f"{m.name}/roller{j}/s{s}")
        return rows, kinds, ids
    rows_def = []
    if isinstance(b, AngularContactPair):
        rows_def = [("row0", b.row, 1.0), ("row1", b.row, -1.0)]
    elif isinstance(b, BallBearing):
        rows_def = [("", b, 1.0)]
    else:
        raise RvtoolInputError(f"bearing of type {type(b).__name__} is not a known bearing; valid: RollerBearing, "
                               "BallBearing, AngularContactPair, CrossedRollerBearing")
    for tag, row, sign in rows_def:
        gamma = row.ball_diameter * math.cos(row.contact_angle) / row.pitch_diameter
        for j in range(row.n_balls):
            r = base(m.cage_phase + 2 * math.pi * j / row.n_balls, gamma, row.pitch_diameter)
            # in the planar model the opposite contact angle of the second row only changes
            # the sign of its axial component; the preload offset loads both rows alike
            r[ref.R_K], r[ref.R_P], r[ref.R_ALPHA] = row.stiffness, 1.5, row.contact_angle
            r[ref.R_A], r[ref.R_SAX], r[ref.R_CLEAR] = row.groove_centre_distance, row.axial_preload_offset, row.radial_clearance
            rows.append(r)
            kinds.append(ref.KIND_BALL)
            ids.append(f"{m.name}/{tag + '/' if tag else ''}ball{j}")
    return rows, kinds, ids


class BearingSet:
    """Any number of mounted bearings between ``n_bodies`` bodies, one kernel launch."""

    def __init__(self, mountings, n_bodies, *, name="bearings", backend="warp", precision="float64", device="cpu"):
        if backend not in ("warp", "numpy"):
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are ['warp', 'numpy']")
        if not mountings:
            raise RvtoolInputError("mountings must contain at least one Mounting")
        self.name, self.n_bodies, self.backend = name, n_bodies, backend
        self.mountings = tuple(mountings)
        self.history = NoHistory()
        fp, ip, ids, owner = [], [], [], []
        for k, m in enumerate(self.mountings):
            for nm in ("inner", "outer"):
                b = getattr(m, nm)
                if not (b == GROUND or 0 <= b < n_bodies):
                    raise RvtoolInputError(f"mountings[{k}].{nm} = {b} is outside the valid range [0, {n_bodies - 1}] or GROUND")
            rows, kinds, rid = _rows(m)
            g = n_bodies
            for r, kd in zip(rows, kinds):
                fp.append(r)
                ip.append((g if m.inner == GROUND else m.inner, g if m.outer == GROUND else m.outer, kd))
                owner.append(k)
            ids += rid
        self.fparams = np.array(fp)
        self.iparams = np.array(ip, dtype=np.int32)
        self.ids = tuple(ids)
        self.owner = np.array(owner)
        self.assembler = PairAssembler(self.iparams[:, 0], self.iparams[:, 1], n_bodies)
        self._pose = np.zeros((n_bodies + 1, 3))
        if backend == "warp":
            from warp_contacts.rolling_elements import RollingElementKernel
            self._kernel = RollingElementKernel(self.fparams, self.iparams, n_bodies, precision, device)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")

    def raw(self, pose):
        self._pose[:-1] = pose
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose)
        return ref.evaluate(self._pose, self.fparams, self.iparams)

    def evaluate(self, pose, vel=None, history=None, check=True):
        if check:
            a = np.asarray(pose)
            if a.shape != (self.n_bodies, 3) or not np.all(np.isfinite(a)):
                raise RvtoolInputError(f"pose must be a finite array of shape ({self.n_bodies}, 3); got {a.shape}")
        Qc, dq, obs = self.raw(pose)
        n = 3 * self.n_bodies
        finite = all_finite(Qc, dq)
        return Evaluation(self.assembler.vector(np.asarray(Qc, float)), self.assembler.matrix(np.asarray(dq, float)),
                          np.zeros((n, n)), np.array(obs, float), (), finite)

    def commit(self, pose, vel=None, evaluation=None):
        return np.array(evaluation.obs if evaluation is not None else self.raw(pose)[2], float)

    def mounting_loads(self, obs):
        """Per mounting: resultant force [N] on the inner ring from its elements."""
        f = obs[:, ref.O_FN][:, None] * obs[:, ref.O_NX:ref.O_NY + 1]
        out = np.zeros((len(self.mountings), 2))
        np.add.at(out, self.owner, -f)
        return out
