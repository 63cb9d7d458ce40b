"""The reducer model behind the orchestrator's :class:`~rvtool.slow.orchestrator.MechanicalWindows`.

A mechanical window of :class:`ReducerWindows` is a quasi-static rotation of
the input over ``window_angle`` (default: one mesh period of the main mesh)
from the declared reference phase, under the declared output torque, at the
declared input speed omega. Each equilibrium of the sequence is one accepted
step of duration Delta a / omega; its contact snapshot (per physical contact of
every observed family, from ``model.observe(q, family).per_contact()``) is
handed to an :class:`~rvtool.slow.exposure.ExposureObserver` on a
:class:`~rvtool.observe.TimeWindows` of length window_angle / omega, so the
window's I_s, I_m and I_F of Eq. (supp_slow_exposure) come from accepted steps
only, through the same observer the driver feeds in time-domain runs.

Contact identities are ``"<family>/<physical contact>"`` (``"pins/wheel0/pin3"``,
``"eccentric_bearings/eccentric_bearing1"``), so a family name is a selector
of :mod:`rvtool.slow.offsets` for all of its contacts.

Involute meshes are observed per tooth flank (the identities of the evaluator's
``gap_offset_ids``, ``"involute_stage/<mesh>/gear_a/tooth<k>/line<l>"``): each row's
tooth pair enters with both of its flanks, each carrying the row's force (load
exposure, film load) and half of the row's sliding speed, so that the two flanks'
sliding exposures sum to the pair's: a heat source mu I_s / tau_w and Archard wear
k_w I_s / A of a flank are its half of the pair's loss (equal shares, declared; the
share of each surface is the wear association's 1.0 to the flank itself).

Sliding speeds are kinematic: the relative velocity of the two material points
at the contact point, tangential part, from ``model.kinematic_state(a, omega)``
(rigid, clearance-free poses and velocities; the elastic deflections of a few
micrometres change them by less than 1e-3 relative). Which bodies a contact
joins is declared per family (:class:`ContactBodies`); families declared as
rolling (rolling-element bearings) get sliding speed 0 (micro-slip is not
modelled), so they carry load exposure but no sliding exposure.

Feedback (:meth:`ReducerWindows.apply_offsets`): the total gap offset of each
contact over all channels is written through
``model.set_gap_offsets(family, {contact: offset})``, which the next contact
evaluation uses (cycloid pins: the deviation sum e of Eq. (gap); lumped
bearings: the enclosing radius; output pins: u_off of Eq. (output_gap)).
Friction. A static solve evaluates the contacts at zero velocity, so the
regularized friction law of Eq. (friction) gives no tangential force. With
``WindowProtocol.sliding_friction`` on, every equilibrium of a window is solved
with the contacts evaluated at the kinematic velocities of its input angle at
speed omega (``model.set_prescribed_velocity``): the quasi-static state of the
steady motion, in which each sliding contact carries mu F_n along its sliding
direction (the elastic velocities, a few um per mesh period times omega, are
neglected as in the sliding speeds). mu per contact written by coupled
lubrication (``apply_offsets(offsets, friction)``) then enters the contact law
of the families that have one (cycloid pins built with ``pin_contact.mu`` > 0;
the output-pin law is frictionless and bearings roll, so their mu stays a heat
source only). With it off (default) the windows are unchanged and mu is kept
for the heat sources and the dissipation figure only.
"""
import math
from dataclasses import dataclass

import numpy as np

from warp_contacts.circle_pairs_ref import O_FT, O_VT

from ..errors import RvtoolInputError, SolverFailure
from ..model import Family
from ..model.reducer import physical_contact
from ..observe.registry import AcceptedStep, ContactSnapshot
from ..observe.windows import TimeWindows
from ..solver.static import StaticSolver
from ..validation import check_finite, check_positive
from .exposure import ExposureObserver, WindowExposure
from .offsets import GapOffsets

SNAPSHOT = "reducer"


@dataclass(frozen=True, kw_only=True)
class WindowProtocol:
    """One mechanical window.

    torque: output torque [N m] (> 0), applied to resist the nominal output rotation.
    input_speed: omega [rad/s] (> 0): sets the accepted duration Delta a / omega of each
    step and the sliding speeds. reference_angle: input angle at which every window
    starts [rad] (the reference phase of the matched protocols). window_angle: input
    angle of one window [rad] (> 0; None: the model's mesh period). steps: accepted
    quasi-static steps per window (>= 2). m: exponent of I_m [-] (> 0), the consuming
    life law's. sliding_friction: evaluate the contacts at the kinematic velocities of the
    steady motion (friction acts in the equilibria; see the module docstring).
    """
    torque: float
    input_speed: float
    reference_angle: float = 0.0
    window_angle: float | None = None
    steps: int = 8
    m: float = 3.0
    sliding_friction: bool = False

    def __post_init__(self):
        for name in ("torque", "input_speed", "m"):
            check_finite(name, getattr(self, name))
            check_positive(name, getattr(self, name))
        check_finite("reference_angle", self.reference_angle)
        if self.window_angle is not None:
            check_finite("window_angle", self.window_angle)
            check_positive("window_angle", self.window_angle)
        if isinstance(self.steps, bool) or not isinstance(self.steps, int) or self.steps < 2:
            raise RvtoolInputError(f"steps = {self.steps!r} is outside the valid range: integers in [2, inf)")
        if not isinstance(self.sliding_friction, bool):
            raise RvtoolInputError(f"sliding_friction = {self.sliding_friction!r} must be True or False")


@dataclass(frozen=True, kw_only=True)
class ContactBodies:
    """Bodies joined by the contacts of one family.

    body_a, body_b: callables contact id (the physical contact, without the family
    prefix) -> body name of ``model.body_names``, or None for the housing/ground
    (body_b only). rolling: True for rolling contacts (sliding speed 0, declared).
    """
    body_a: object = None
    body_b: object = None
    rolling: bool = False

    def __post_init__(self):
        if not self.rolling and not callable(self.body_a):
            raise RvtoolInputError("body_a must be callable (contact id -> body name) unless rolling=True")
        if self.body_b is not None and not callable(self.body_b):
            raise RvtoolInputError("body_b must be None (housing) or callable (contact id -> body name or None)")


def involute_stage_bodies(model) -> ContactBodies:
    """Declaration of a model's involute meshes: a tooth flank contact
    ``<mesh>/gear_a|gear_b/tooth<k>/line<l>`` joins the two bodies of its mesh (the mesh's
    ``body_a`` / ``body_b``, indices of the model's bodies; the housing for GROUND), for every
    topology with an involute stage (the small-tooth-difference drive: wheel and fixed ring; the
    RV: sun pinion and crank gear)."""
    meshes = {m.name: m for m in model.family_element(Family.INVOLUTE_STAGE).evaluator.meshes}
    names = model.body_names

    def body(index):
        return None if index < 0 else names[index]
    return ContactBodies(body_a=lambda c: body(meshes[c.split("/")[0]].body_a),
                         body_b=lambda c: body(meshes[c.split("/")[0]].body_b))


def std_involute_contact_bodies(model) -> dict:
    """The small-tooth-difference drive's declaration (:mod:`rvtool.assembly.std_involute`): its mesh
    by :func:`involute_stage_bodies`; output pins and bearings as in the cycloid drive."""
    out = cycloid_contact_bodies()
    del out[Family.PINS]
    out[Family.INVOLUTE_STAGE] = involute_stage_bodies(model)
    return out


def cycloid_contact_bodies() -> dict:
    """The cycloid drive's declaration (:mod:`rvtool.assembly.cycloid` contact ids): a ring-pin
    contact ``wheel<k>/pin<j>`` joins wheel k and the housing (pins fixed in the housing); an
    output-pin contact ``output_pins/pin<j>/wheel<k>`` joins wheel k and the flange; the
    bearings roll."""
    return {Family.PINS: ContactBodies(body_a=lambda c: c.split("/")[0], body_b=None),
            Family.OUTPUT_PINS: ContactBodies(body_a=lambda c: c.split("/")[2], body_b=lambda c: "flange"),
            Family.ECCENTRIC_BEARINGS: ContactBodies(rolling=True),
            Family.MAIN_BEARINGS: ContactBodies(rolling=True),
            Family.INPUT_BEARINGS: ContactBodies(rolling=True)}


#: Torque fractions of the fallback start: a cold start (stiffness homotopy and load ramp of
#: :class:`StaticSolver`) at the full torque fails on RD-40 with a nonuniform wear pattern of a few
#: micrometres (measured: 1,000 h of wear) and succeeds at 10 %; from there the torque is raised
#: through warm-started equilibria.
START_FRACTIONS = (0.1, 0.25, 0.5, 0.75, 1.0)


def loaded_start(model, torque, angle) -> StaticSolver:
    """A :class:`StaticSolver` holding the equilibrium at input ``angle`` under ``torque`` [N m]:
    a cold start at the torque, or, where it fails, by raising the torque over
    :data:`START_FRACTIONS` from a cold start at the first."""
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(model.ratio) * torque)
    try:                # a direct cold start where it succeeds (inside the free play of a design with
        solver.solve(angle)   # pin clearance the 10 % start is the one that fails)
        return solver
    except SolverFailure:
        pass
    for k, f in enumerate(START_FRACTIONS):
        model.set_output_torque(-np.sign(model.ratio) * f * torque)
        solver.solve(angle, None if k == 0 else angle)
    return solver


def _material_velocity(pose, vel, p):
    """Velocity [m/s] of the material point of a planar body (pose, vel: (3,)) at points p (n, 2)."""
    r = p - pose[:2]
    return np.column_stack([vel[0] - vel[2] * r[:, 1], vel[1] + vel[2] * r[:, 0]])


class ReducerWindows:
    """:class:`~rvtool.slow.orchestrator.MechanicalWindows` of a :class:`~rvtool.model.ReducerModel`.

    model: the reducer. protocol: :class:`WindowProtocol`. bodies: Family ->
    :class:`ContactBodies` (default :func:`cycloid_contact_bodies`); its families
    present in the model are observed. solver: a :class:`StaticSolver` of the model
    (default: a new one).
    """

    def __init__(self, model, protocol: WindowProtocol, *, bodies=None, solver=None):
        if not isinstance(protocol, WindowProtocol):
            raise RvtoolInputError(f"protocol must be a WindowProtocol; got {type(protocol).__name__}")
        bodies = cycloid_contact_bodies() if bodies is None else dict(bodies)
        self.model, self.protocol = model, protocol
        self.families = tuple(f for f in model.families if f in bodies)
        if not self.families:
            raise RvtoolInputError(f"bodies declares none of the model's families {[f.value for f in model.families]}")
        self.bodies = {f: bodies[f] for f in self.families}
        self.solver = None
        self.window_angle = float(protocol.window_angle or model.mesh_period)
        self.offsets = GapOffsets.none()
        self.friction = None
        self.windows_run = 0
        self.last_q = None
        self.last_te = None
        self.last_friction_power = None
        self.last_states = ()     # (input angle [rad], accepted duration [s], q) of the last window's steps
        self.friction_written = set()

    # -- contact identities ------------------------------------------------------------
    def contact_ids(self, family) -> tuple:
        """Window identities ``"<family>/<contact>"`` of ``family``, in observation order (a family
        whose evaluator names its own offset identities: those, e.g. the tooth flanks of a mesh)."""
        own = self._own_ids(family)
        if own is None:
            q = np.zeros(self.model.mbs.systemData.ODE2Size())
            own, _ = self.model.observe(q, family).per_contact()
        return tuple(f"{Family(family).value}/{c}" for c in own)

    def _own_ids(self, family):
        """The evaluator's own contact identities (``gap_offset_ids``), or None for row contacts."""
        return getattr(self.model.family_element(family).evaluator, "gap_offset_ids", None)

    def _rows(self, q, fam):
        """(observation, contact of every row entry, row index of every entry): one entry per row
        (its physical contact), or, where the evaluator names its own identities, one per flank of
        the row's tooth pair (both flanks carry the row's force)."""
        ob = self.model.observe(q, fam)
        ev = self.model.family_element(fam).evaluator
        if self._own_ids(fam) is None:
            return ob, [physical_contact(r) for r in ob.ids], np.arange(len(ob.ids))
        fa, fb = ev.flank_ids(ob.obs)
        return ob, fa + fb, np.concatenate([np.arange(len(fa)), np.arange(len(fb))])

    # -- one window --------------------------------------------------------------------------
    def _snapshot(self, q, angle):
        kin = self.model.kinematic_state(angle, self.protocol.input_speed)
        ids, F, slip, pos, nrm = [], [], [], [], []
        for fam in self.families:
            ob, row_contact, src = self._rows(q, fam)
            names = tuple(dict.fromkeys(row_contact))
            index = {c: k for k, c in enumerate(names)}
            col = np.fromiter((index[c] for c in row_contact), int, len(row_contact))
            f_row = ob.normal_force[src]
            p_row, n_row = ob.position[src], ob.normal[src]
            Fc = np.zeros(len(names))
            np.add.at(Fc, col, f_row)
            decl = self.bodies[fam]
            if decl.rolling:
                v_row = np.zeros(len(f_row))
            else:
                va = np.zeros((len(f_row), 2))
                vb = np.zeros((len(f_row), 2))
                for r, c in enumerate(row_contact):
                    a = self.model.body_index(decl.body_a(c))
                    va[r] = _material_velocity(kin.poses[a], kin.velocities[a], p_row[r:r + 1])[0]
                    b = None if decl.body_b is None else decl.body_b(c)
                    if b is not None:
                        b = self.model.body_index(b)
                        vb[r] = _material_velocity(kin.poses[b], kin.velocities[b], p_row[r:r + 1])[0]
                dv = va - vb
                t = np.column_stack([-n_row[:, 1], n_row[:, 0]])
                v_row = np.abs(np.sum(dv * t, axis=1))
                if self._own_ids(fam) is not None:
                    v_row = 0.5 * v_row      # a flank takes half its pair's sliding exposure (module docstring)
            # per physical contact: rows summed (force), load-weighted (position, normal, sliding speed);
            # an unloaded contact takes its rows' plain mean
            w = np.zeros(len(names))
            np.add.at(w, col, f_row)
            cnt = np.bincount(col, minlength=len(names)).astype(float)
            wr = np.where(w[col] > 0.0, f_row / np.where(w[col] > 0.0, w[col], 1.0), 1.0 / cnt[col])
            pc, nc, vc = np.zeros((len(names), 2)), np.zeros((len(names), 2)), np.zeros(len(names))
            np.add.at(pc, col, wr[:, None] * p_row)
            np.add.at(nc, col, wr[:, None] * n_row)
            np.add.at(vc, col, wr * v_row)
            ids += [f"{fam.value}/{c}" for c in names]
            F.append(np.maximum(Fc, 0.0))
            slip.append(vc)
            pos.append(pc)
            nrm.append(nc)
        return ContactSnapshot(ids=tuple(ids), normal_force=np.concatenate(F), slip_speed=np.concatenate(slip),
                               position=np.vstack(pos), normal=np.vstack(nrm))

    def window(self, reference_angle: float | None = None) -> WindowExposure:
        """One window from ``reference_angle`` (default: the protocol's) at the offsets in force."""
        p = self.protocol
        a0 = float(p.reference_angle if reference_angle is None else reference_angle)
        omega = p.input_speed
        model, solver = self.model, self.solver
        model.set_output_torque(-np.sign(model.ratio) * p.torque)
        observer = ExposureObserver(TimeWindows(self.window_angle / omega, m=p.m))
        da = self.window_angle / p.steps
        i_out = model.output_index
        te, work, states = [], 0.0, []
        try:
            self._prescribe(a0)
            # every window starts loaded from a cold start at a fraction of the torque: the offsets written
            # since the last window move the equilibrium too far for a warm start (measured after wear updates)
            self.solver = solver = loaded_start(model, p.torque, a0)
            q_prev = solver.q.copy()
            a_prev = solver.last_angle
            # steps + 1 steps: the last one enters the next window, which closes this one
            for j in range(1, p.steps + 2):
                self._prescribe(a0 + j * da)
                q = solver.solve(a0 + j * da, a_prev).copy()
                a = solver.last_angle       # a kink shift of <= 1e-5 rad is kept in the clock, not hidden
                snap = self._snapshot(q, a)
                observer.on_accepted(AcceptedStep(index=j - 1, t_start=(a_prev - a0) / omega, dt=(a - a_prev) / omega,
                                                  q_start=q_prev, q_end=q, snapshots={SNAPSHOT: snap}))
                if j <= p.steps:
                    te.append(q[i_out] - model.kinematic_output(a))
                    states.append((a, (a - a_prev) / omega, q))
                    work += self._friction_power(q) * (a - a_prev) / omega
                q_prev, a_prev = q, a
        finally:
            if p.sliding_friction:
                model.set_prescribed_velocity(None)
        self.last_q = q_prev
        self.last_te = np.array(te)
        self.last_states = tuple(states)
        self.last_friction_power = work * omega / (p.steps * da)
        done = observer.completed()
        if not done:
            raise RvtoolInputError(f"the window from input angle {a0} rad did not complete (steps = {p.steps}); "
                                   "valid: a solver that advances the input angle monotonically")
        self.windows_run += 1
        return done[0]

    def _prescribe(self, angle):
        """The kinematic velocities at ``angle`` as the contacts' evaluation velocity (sliding_friction)."""
        if self.protocol.sliding_friction:
            kin = self.model.kinematic_state(angle, self.protocol.input_speed)
            self.model.set_prescribed_velocity(self.model.body_vector(kin.velocities))

    def _friction_power(self, q) -> float:
        """sum |F_t v_t| [W] of the contact law's friction over the families that have one, at state q
        with the velocities the contacts are evaluated at (zero without sliding_friction)."""
        P = 0.0
        for fam in self.friction_families():
            name, rows = self.model.families[fam]
            obs = self.model.elements[name].evaluation_at(q).obs[rows]
            P += float(np.sum(np.abs(obs[:, O_FT] * obs[:, O_VT])))
        return P

    def te_pp(self) -> float:
        """Peak-to-peak [rad] of the last window's transmission error over its steps (:attr:`last_te`:
        output coordinate minus its kinematic value, Eq. (obs_te) with the kinematic reference, so its
        mean is the loaded wind-up)."""
        if self.last_te is None:
            raise RvtoolInputError("no window has been run yet")
        return float(np.ptp(self.last_te))

    # -- MechanicalWindows -----------------------------------------------------------------
    def run_window(self, state) -> WindowExposure:
        """One window at the slow state in force (the offsets were written by :meth:`apply_offsets`)."""
        return self.window()

    def apply_offsets(self, offsets: GapOffsets, friction: dict | None) -> None:
        """Write the total gap offset of every contact (sum over channels) through
        ``model.set_gap_offsets``; keep mu per contact (coupled lubrication) for the sources."""
        if not isinstance(offsets, GapOffsets):
            raise RvtoolInputError(f"offsets must be a GapOffsets; got {type(offsets).__name__}")
        for fam in self.families:
            ids = self.contact_ids(fam)
            if not any(o for o in (offsets.offset(i) for i in ids)) and not any(
                    self.model.gap_offsets(fam).values()):
                continue   # nothing written and nothing to reset: the element stays as built
            prefix = fam.value + "/"
            self.model.set_gap_offsets(fam, {i[len(prefix):]: offsets.offset(i) for i in ids})
        self.offsets = offsets
        self.friction = None if friction is None else dict(friction)
        if self.protocol.sliding_friction:
            self._write_friction(self.friction)

    def friction_families(self) -> tuple:
        """Families whose contact law takes a friction coefficient (cycloid pins built with friction)."""
        out = []
        for fam in self.families:
            ev = self.model.family_element(fam).evaluator
            rows = getattr(ev, "friction_rows", None)
            if rows is not None and np.any(rows):
                out.append(fam)
        return tuple(out)

    def _write_friction(self, friction):
        """mu per contact into the contact law of :meth:`friction_families` (None: the built mu)."""
        fams = self.friction_families()
        if friction is not None and not fams:
            raise RvtoolInputError("coupled friction with sliding_friction=True needs a family whose contact law has "
                                   "friction; valid: a cycloid design with pin_contact.mu in (0, inf)")
        for fam in fams:
            if friction is None:
                if fam in self.friction_written:
                    self.model.set_friction(fam, None)
                    self.friction_written.discard(fam)
                continue
            prefix = fam.value + "/"
            table = {i[len(prefix):]: float(friction[i]) for i in self.contact_ids(fam) if i in friction}
            self.model.set_friction(fam, table)
            self.friction_written.add(fam)

    def offsets_by_channel(self) -> dict:
        """{channel: {contact id: offset [m]}} of the offsets in force (nonzero entries)."""
        out = {}
        for ch in self.offsets.by_channel:
            row = {}
            for fam in self.families:
                for i in self.contact_ids(fam):
                    v = self.offsets.channel_offset(ch, i)
                    if v != 0.0:
                        row[i] = v
            out[ch] = row
        return out


def dissipation(exposure: WindowExposure, mu) -> float:
    """Mean sliding-loss power sum_c mu_c I_s,c / tau_w [W]; mu: one value or id -> value."""
    if isinstance(mu, dict):
        m = np.array([float(mu[i]) for i in exposure.ids])
    else:
        m = np.full(len(exposure), float(mu))
    return float(np.sum(m * exposure.I_s) / exposure.tau_w)
