"""Output-pin family behind the evaluator protocol of
:class:`exudyn_user_elements.contact_element.ContactElement`.

Bodies are planar rigid bodies (x, y, theta): the flange and the wheels of
one :class:`~rvtool.output_pins.spec.OutputPinMechanism`. Every slice of
every (pin, wheel) contact is one observed contact, with the columns of
:mod:`warp_contacts.circle_pairs_ref` (normal force, zero slip speed,
gap = -effective approach, contact point, direction of the force on the
wheel, tangential force). Without friction the family has no committed
history; its history object is empty. With anchor friction (plain mode,
``mechanism.friction``) every slice row carries an anchor, committed once per
accepted step (:class:`rvtool.contact.evaluator.ContactHistory`). Damping is
not part of this family, so dQ/dv = 0.
"""
import numpy as np

from rvtool.contact.assembly import BlockAssembler
from rvtool.contact.evaluator import (ContactHistory, Evaluation, StagedLaunch, all_finite,
                                      gap_offset_rows)
from warp_contacts import anchor_ref
from warp_contacts import circle_pairs_ref as cref
from warp_contacts import output_pins_ref as ref

from ..errors import RvtoolInputError
from ..validation import check_choice, check_body_state
from .spec import OutputPinMechanism, PinMode

GROUND = -1
"""Body index of the fixed ground (the flange may be fixed)."""


class NoHistory:
    """Committed history of a family without history variables (no arrays)."""


class OutputPinEvaluator(StagedLaunch):
    """Evaluates an output-pin mechanism at absolute body poses (nb, 3).

    flange: body index of the flange (or ``GROUND``); wheels: body indices of
    the wheels (one per wheel midplane of the mechanism); n_bodies: number of
    bodies of the contact element. backend "warp" | "numpy", precision
    "float64" | "float32", device "cpu" | "cuda:N".
    flange_bodies: plain mode only, optionally the body carrying the pin of every (pin, wheel)
    row (pins outer, wheels inner) instead of ``flange``: the station bodies of elastic pins
    (:mod:`rvtool.contact.pin_closure`).
    """

    def __init__(self, mechanism: OutputPinMechanism, *, name="output_pins", flange=0, wheels=None, n_bodies=None,
                 backend="warp", precision="float64", device="cpu", flange_bodies=None):
        if not isinstance(mechanism, OutputPinMechanism):
            raise RvtoolInputError(f"mechanism must be an OutputPinMechanism; got {type(mechanism).__name__}")
        check_choice("backend", backend, ("warp", "numpy"))
        check_choice("precision", precision, ("float64", "float32"))
        if backend == "numpy" and precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")
        wheels = tuple(range(1, mechanism.n_wheels + 1)) if wheels is None else tuple(int(w) for w in wheels)
        if n_bodies is None:
            n_bodies = 1 + mechanism.n_wheels if flange != GROUND else mechanism.n_wheels
        self.n_bodies = int(n_bodies)
        for nm, b in [("flange", flange)] + [(f"wheels[{k}]", w) for k, w in enumerate(wheels)]:
            if not (b == GROUND and nm == "flange") and not 0 <= b < self.n_bodies:
                raise RvtoolInputError(f"{nm} = {b} is outside the valid range [0, {self.n_bodies - 1}]"
                                       + (" or GROUND (-1)" if nm == "flange" else ""))
        fl = self.n_bodies if flange == GROUND else int(flange)   # ground row of the padded pose array
        self.mechanism = mechanism
        self.name = name
        self.backend = backend
        self.precision = precision
        self.mode = mechanism.mode
        self.stations = mechanism.stations
        self.fparams, self.iparams = mechanism.packed(fl, wheels)
        if flange_bodies is not None:
            fb = np.asarray(flange_bodies, int)
            if self.mode != PinMode.PLAIN or fb.shape != (len(self.iparams),) or fb.min() < 0 or fb.max() >= self.n_bodies:
                raise RvtoolInputError(f"flange_bodies must give one body in [0, {self.n_bodies - 1}] per plain "
                                       f"(pin, wheel) row ({len(self.iparams)}); got shape {fb.shape} in mode "
                                       f"{self.mode.value!r}")
            self.iparams[:, ref.J_FLANGE] = fb
        ns = mechanism.n_slices
        if self.mode == PinMode.SHARED:
            self.ids = tuple(f"{name}/pin{p}/wheel{w}/slice{s}" for p in range(mechanism.n_pins)
                             for w in range(2) for s in range(ns))
        else:
            self.ids = tuple(f"{name}/pin{p}/wheel{w}/slice{s}" for p in range(mechanism.n_pins)
                             for w in range(mechanism.n_wheels) for s in range(ns))
        self._finish(device)

    def _body_columns(self):
        return [ref.I_FLANGE, ref.I_WHEEL0, ref.I_WHEEL1] if self.mode == PinMode.SHARED else [ref.J_FLANGE, ref.J_WHEEL]

    def _finish(self, device):
        """The assembler, history and kernel of the rows in ``fparams`` / ``iparams``."""
        self.assembler = BlockAssembler(self.iparams[:, self._body_columns()], self.n_bodies)
        self.anchor = self.mechanism.anchors
        self.anchor_params = self.mechanism.anchor_params() if self.anchor else None
        self.history = ContactHistory(len(self.ids)) if self.anchor else NoHistory()
        self._pose = np.zeros((self.n_bodies + 1, 3))
        self.launches = 0
        self._staged = None
        if self.backend == "warp":
            from warp_contacts.output_pins import OutputPinKernel
            self._kernel = OutputPinKernel(self.fparams, self.iparams, self.stations, self.n_bodies + 1,
                                           self.mode.value, self.precision, device, anchor_params=self.anchor_params)

    @classmethod
    def concatenated(cls, sets, nb, *, names=None, precision="float64", device="cpu"):
        """The evaluator of B built evaluators side by side (copy c's bodies offset by c nb, the
        ground row at B nb; ids prefixed by ``names[c][0]`` + "/" where given): their built rows
        concatenated, one launch for all. Copies of one mechanism without anchors only (the
        width slices of tilting wheels, :class:`rvtool.contact.skew.SkewSlices`)."""
        s, B = sets[0], len(sets)
        if any(sc.anchor for sc in sets) or any(sc.mechanism is not s.mechanism or sc.backend != s.backend for sc in sets):
            raise RvtoolInputError("output pins are stacked only as copies of one mechanism without stick--slip "
                                   "anchors (valid: output_pins friction without anchors)")
        self = object.__new__(cls)
        self.n_bodies, self.mechanism, self.name, self.backend = int(B * nb), s.mechanism, s.name, s.backend
        self.precision, self.mode, self.stations = precision, s.mode, s.stations
        cols = s._body_columns()
        ip = []
        for c, sc in enumerate(sets):
            i = sc.iparams.copy()
            i[:, cols] = np.where(i[:, cols] >= sc.n_bodies, B * nb, i[:, cols] + c * nb)
            ip.append(i)
        # the built rows (a slow-state gap offset of a built evaluator is not copied)
        self.fparams = np.concatenate([getattr(sc, "_built_fparams", sc.fparams) for sc in sets])
        self.iparams = np.concatenate(ip)
        self.ids = tuple((f"{names[c][0]}/" if names else "") + i for c, sc in enumerate(sets) for i in sc.ids)
        self._finish(device)
        return self

    def raw(self, pose, history=None):
        """Per-row results (layout of :mod:`warp_contacts.output_pins_ref`) at poses (nb, 3); with
        anchors also ``ft`` (N, ns) and the trial history ``trial`` (flags, anchor_A, anchor_B,
        slip distance) from the committed ``history`` (default: the evaluator's own)."""
        self.launches += 1      # the kernel's buffers change: launched evaluations read afresh
        self._pose[:-1] = pose
        if self.anchor:
            hist = history or self.history
            if self.backend == "warp":
                r = self._kernel.evaluate(self._pose, history=hist.as_tuple())
            else:
                r = ref.evaluate_plain_anchor(self._pose, self.fparams, self.iparams, self.stations,
                                              self.anchor_params, *hist.as_tuple())
            flag, a, b = (np.array(x) for x in r["trial"])
            slip = hist.slip_distance + anchor_ref.slip_increment(hist.active, flag, hist.anchor_a, a)
            return dict(r, trial=(flag, a, b, slip))
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose)
        if self.mode == PinMode.SHARED:
            return ref.evaluate_shared(self._pose, self.fparams, self.iparams, self.stations)
        return ref.evaluate_plain(self._pose, self.fparams, self.iparams, self.stations)

    def _observations(self, slices, ft=None):
        s = np.asarray(slices, np.float64).reshape(-1, ref.N_SLICE_COLS)
        obs = np.zeros((s.shape[0], cref.N_OBS))
        obs[:, cref.O_FN] = s[:, ref.S_FORCE]
        obs[:, cref.O_GAP] = -s[:, ref.S_APPROACH]
        obs[:, cref.O_PX:cref.O_PY + 1] = s[:, ref.S_PX:ref.S_PY + 1]
        obs[:, cref.O_NX:cref.O_NY + 1] = s[:, ref.S_NX:ref.S_NY + 1]
        if ft is not None:
            obs[:, cref.O_FT] = np.asarray(ft, np.float64).reshape(-1)
        return obs

    def energy_law(self):
        """The per-slice constants of the energy account (:class:`rvtool.observe.energy.ContactEnergyLaw`):
        slice coefficient k / n_s and exponent of the plain rows, anchor stiffness and friction code
        (the shared mode's condensed law has no per-slice potential: refused by name)."""
        from ..observe.energy import ContactEnergyLaw
        if self.mode != PinMode.PLAIN:
            raise RvtoolInputError(f"the energy account needs mode = 'plain' output pins; {self.name!r} is "
                                   f"{self.mode.value!r}")
        ns = len(self.stations)
        n = len(self.ids)
        k = np.repeat(self.fparams[:, ref.Q_K] / ns, ns)
        p = np.repeat(self.fparams[:, ref.Q_EXP], ns)
        kt = self.anchor_params[:, anchor_ref.ANCHOR_KT] if self.anchor else np.zeros(n)
        model = np.full(n, cref.FRICTION_ANCHOR if self.anchor else cref.FRICTION_NONE, np.int32)
        return ContactEnergyLaw(normal_stiffness=k, normal_exponent=p, tangential_stiffness=kt, friction_model=model)

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"output pins '{self.name}'", pose, vel, (self.n_bodies, 3))

    def evaluate(self, pose, vel, history=None, check=True):
        """Assembled :class:`rvtool.contact.evaluator.Evaluation` at poses/velocities (nb, 3).

        ``history``: the committed anchor history to read (default: the evaluator's own;
        unused without anchors); ``check=False`` skips the input checks (the contact
        element checks itself).
        """
        if check:
            self.check_state(pose, vel)
        r = self.raw(pose, history)
        Q = self.assembler.vector(np.asarray(r["Q"], np.float64))
        K = self.assembler.matrix(np.asarray(r["dQdq"], np.float64))
        finite = all_finite(Q, K)
        return Evaluation(Q, K, np.zeros_like(K), self._observations(r["slices"], r.get("ft")),
                          r["trial"] if self.anchor else (), finite)

    # -- rows summed on the device (the merged element: warp_contacts.segment_sum) ----------
    velocity_rows = False
    """No damping in this family: no velocity tangent rows."""

    stages_velocity = False
    """The kernel reads poses only (the tilt input stays zero: this evaluator never tilts)."""

    def stages_history(self):
        """True if the kernel reads the committed history (anchor rows)."""
        return bool(self.anchor)

    def launched_field(self, name):
        """Field ``name`` of :class:`Evaluation` from the outputs of the last launch."""
        r = self._staged.read
        if name == "Q":
            return self.assembler.vector(np.asarray(r("q"), np.float64))
        if name == "dQdq":
            return self.assembler.matrix(np.asarray(r("dqdq"), np.float64))
        if name == "dQdv":
            return np.zeros((self.assembler.n,) * 2)
        if name == "obs":
            return self._observations(r("slices"), r("ft") if self.anchor else None)
        if name == "trial_history":
            return self.launched_anchor_history()
        return all_finite(self.launched_field("Q"), self.launched_field("dQdq"))

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per observation row (positive opens the gap), written to u_off of
        Eq. (output_gap) of the row's (pin, wheel) contact, absolute over the built parameters;
        the slices of one contact must carry one offset. Zeros restore the built rows bit for bit."""
        off = gap_offset_rows(offsets, len(self.ids), self.name)
        ns = self.mechanism.n_slices
        per_contact = off.reshape(-1, ns)
        if np.any(per_contact != per_contact[:, :1]):
            raise RvtoolInputError(f"gap offsets of {self.name!r} differ between the slices of one (pin, wheel) "
                                   "contact; valid: one offset per contact (u_off is a contact parameter)")
        u = per_contact[:, 0]
        if not hasattr(self, "_built_fparams"):
            self._built_fparams = self.fparams.copy()
        fp = self._built_fparams.copy()
        if self.mode == PinMode.SHARED:           # rows per pin, ids per (pin, wheel 0/1)
            fp[:, ref.P_OFF0] += u[0::2]
            fp[:, ref.P_OFF1] += u[1::2]
        else:                                      # rows per (pin, wheel), in id order
            fp[:, ref.Q_OFF] += u
        self.fparams = fp
        if self.backend == "warp":
            self._kernel.set_parameters(fp)

    def commit(self, pose, vel, evaluation=None):
        """Commit the anchors (if any) at the accepted state and return its observation array (N, 8).

        ``evaluation``: the element's cached evaluation at exactly this state from the
        committed history, reused instead of a second launch.
        """
        if evaluation is not None:
            if self.anchor:
                self.history.assign(evaluation.trial_history)
            return np.array(evaluation.obs, np.float64)
        r = self.raw(pose)
        if self.anchor:
            self.history.assign(r["trial"])
        return self._observations(r["slices"], r.get("ft"))
