"""Energy account of a run, from its accepted states only.

The driver (:func:`rvtool.solver.simulate` with ``energy=``) samples the
system once at the initial state and once per accepted step, after the
contact history of that step has been committed; trial evaluations, Newton
iterations and rejected attempts never reach the account. From consecutive
samples n, n+1 every work term is integrated with the trapezoidal rule on the
coordinate increments, W_n = 1/2 (f_n + f_{n+1}) . (q_{n+1} - q_n): for the
trapezoidal member of Eq. (alpha_parameters) (rho_inf = 1) and linear forces
this is the rule under which the discrete equations of motion, Eq. (eom),
conserve energy exactly, so the balance residual

    r = W_drive + W_load - (T_end - T_start) - (V_end - V_start) - D_friction - D_damping

measures the algorithmic dissipation of rho_inf < 1 plus the quadrature error
of nonlinear forces, and nothing else.

Terms and their sources (the items rvtool builds; any other Exudyn item is
refused with a named error, because its energy could not be attributed):

* kinetic energy T = 1/2 v^T M v at the ends: ``RigidBody2D``, ``Mass1D``,
  ``MassPoint2D``, ``MassPoint`` and the mass matrices of ``GenericODE2``;
* drive work: every ``CoordinateConstraint`` (C = f_1 q_m1 - q_m0 - offset(t),
  reaction -C_q^T lambda with lambda the algebraic coordinate); constraints
  with a constant offset do no work up to the Newton tolerance;
* load work: ``LoadCoordinate`` values and the constant ``forceVector`` of
  ``GenericODE2``;
* elastic energy V: ``CoordinateSpringDamper`` 1/2 k (q_m1 - q_m0 - offset)^2,
  reduced structures 1/2 q^T K q (``GenericODE2`` stiffness matrix), and per
  contact family the normal potential k delta^(p+1)/(p+1) of Eq.
  (normal_force) (or the family's own potential: the involute series law of
  Eq. (series_contact) in closed form, a ball of Eq. (ball_bearing) by
  quadrature, :attr:`ContactEnergyLaw.normal_potential`) and the anchor's
  tangential storage F_t^2/(2 k_t);
* damping dissipation: spring dampers, structural damping matrices, and per
  contact family the damping part F_n - k delta^p of the normal force on the
  indentation increments;
* friction dissipation per contact family: for the anchor model
  1/2 (|F_t,n| + |F_t,n+1|) Delta s with Delta s the committed anchor
  projection of the step (the dissipation definition compatible with the
  recoverable tangential storage), for the regularized law of Eq. (friction)
  -1/2 (F_t v_t |_n + F_t v_t |_{n+1}) dt.

Switching the account off costs nothing: without ``energy=`` the driver never
creates or samples one.
"""
from dataclasses import dataclass

import numpy as np

from warp_contacts import circle_pairs_ref as ref

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_range

#: Exudyn object types whose energy the account attributes.
MASS_TYPES = ("RigidBody2D", "Mass1D", "MassPoint2D", "MassPoint")
SUPPORTED_OBJECT_TYPES = MASS_TYPES + ("GenericODE2", "ConnectorCoordinate", "ConnectorCoordinateSpringDamper",
                                       "Ground")
SUPPORTED_LOAD_TYPES = ("Coordinate",)
#: Relative asymmetry of a structural stiffness matrix above which 1/2 q^T K q is no potential.
STIFFNESS_SYMMETRY_TOL = 1e-10


@dataclass(frozen=True, kw_only=True, eq=False)
class ContactEnergyLaw:
    """Per-contact constants a contact family declares for its energy split.

    normal_stiffness: k [N m^-p] of Eq. (normal_force), shape (N,).
    normal_exponent: p [-], shape (N,).
    tangential_stiffness: k_t [N/m] of the anchor model, shape (N,) (ignored
    for other friction models).
    friction_model: (N,) codes ``circle_pairs_ref.FRICTION_*``.
    normal_potential: None (the power law k delta^p above), or a callable
    ``obs (N, >= 8) -> (F_e (N,), V (N,))`` giving each row's elastic normal
    force [N] and normal potential [J] from its observation row, for a family
    whose normal law is not a power of the approach (the involute series law of
    Eq. (series_contact), a ball of Eq. (ball_bearing)); normal_stiffness and
    normal_exponent are then unused and may be omitted.
    """
    normal_stiffness: np.ndarray | None = None
    normal_exponent: np.ndarray | None = None
    tangential_stiffness: np.ndarray
    friction_model: np.ndarray
    normal_potential: object = None

    def __post_init__(self):
        kt = np.asarray(self.tangential_stiffness, np.float64)
        n = kt.shape[0] if kt.ndim == 1 else -1
        if n < 1:
            raise RvtoolInputError(f"tangential_stiffness must be a 1-D array with one entry per contact; got shape "
                                   f"{kt.shape}")
        if self.normal_potential is not None and not callable(self.normal_potential):
            raise RvtoolInputError(f"normal_potential must be None or a callable obs -> (F_e, V); got "
                                   f"{type(self.normal_potential).__name__}")
        if self.normal_potential is None and (self.normal_stiffness is None or self.normal_exponent is None):
            raise RvtoolInputError("normal_stiffness and normal_exponent must be given unless normal_potential is")
        power = self.normal_potential is None
        arrays = {"normal_stiffness": np.asarray(self.normal_stiffness if power else np.zeros(n), np.float64),
                  "normal_exponent": np.asarray(self.normal_exponent if power else np.ones(n), np.float64),
                  "tangential_stiffness": kt}
        for name, a in arrays.items():
            if a.shape != (n,):
                raise RvtoolInputError(f"{name} must have shape ({n},); got {a.shape}")
        check_nonnegative("normal_stiffness", arrays["normal_stiffness"])
        check_range("normal_exponent", arrays["normal_exponent"], 1.0)
        check_nonnegative("tangential_stiffness", arrays["tangential_stiffness"])
        model = np.asarray(self.friction_model)
        valid = (ref.FRICTION_NONE, ref.FRICTION_REGULARIZED, ref.FRICTION_ANCHOR)
        if model.shape != (n,) or not np.isin(model, valid).all():
            raise RvtoolInputError(f"friction_model must have shape ({n},) with codes in {list(valid)}; got "
                                   f"{model!r:.200}")
        anchor_without_kt = (model == ref.FRICTION_ANCHOR) & (arrays["tangential_stiffness"] <= 0)
        if anchor_without_kt.any():
            raise RvtoolInputError(f"tangential_stiffness must be > 0 for anchor contacts; zero at contacts "
                                   f"{np.flatnonzero(anchor_without_kt)[:4].tolist()} (valid range (0, inf) N/m)")
        for name, a in arrays.items():
            object.__setattr__(self, name, a)
        object.__setattr__(self, "friction_model", model.astype(np.int32))

    @classmethod
    def from_circle_set(cls, contact_set):
        """The law of a :class:`rvtool.contact.circle_set.CircleContactSet`."""
        cs = contact_set.contacts
        return cls(normal_stiffness=np.array([c.normal.stiffness for c in cs]),
                   normal_exponent=np.array([c.normal.p for c in cs]),
                   tangential_stiffness=np.array([c.friction.tangential_stiffness for c in cs]),
                   friction_model=np.array([int(c.friction.model) for c in cs]))

    def split(self, obs):
        """Per-contact (indentation delta [m], elastic normal force k delta^p [N], normal potential [J],
        tangential storage [J]) from observation rows (N, 8) (columns ``circle_pairs_ref.O_*``)."""
        delta = -obs[:, ref.O_GAP]
        on = delta > 0
        d = np.where(on, delta, 0.0)
        if self.normal_potential is not None:
            fe, v_n = (np.asarray(x, np.float64) for x in self.normal_potential(obs))
            fe, v_n = np.where(on, fe, 0.0), np.where(on, v_n, 0.0)
        else:
            k, p = self.normal_stiffness, self.normal_exponent
            fe = np.where(on, k * d ** p, 0.0)
            v_n = np.where(on, fe * d / (p + 1.0), 0.0)
        anchor = self.friction_model == ref.FRICTION_ANCHOR
        kt = np.where(anchor, self.tangential_stiffness, 1.0)
        v_t = np.where(anchor, 0.5 * obs[:, ref.O_FT] ** 2 / kt, 0.0)
        return delta, fe, v_n, v_t


class _Family:
    """One contact element seen by the account."""

    def __init__(self, element, law):
        if law is None and hasattr(element.evaluator, "energy_law"):
            law = element.evaluator.energy_law()     # the family declares its own law
        if law is None:
            contact_set = getattr(element.evaluator, "set", None)
            if contact_set is None or not hasattr(contact_set, "contacts"):
                raise RvtoolInputError(f"laws[{element.name!r}] must be given: contact family "
                                       f"{type(element.evaluator).__name__} declares no ContactEnergyLaw")
            law = ContactEnergyLaw.from_circle_set(contact_set)
        if not isinstance(law, ContactEnergyLaw):
            raise RvtoolInputError(f"laws[{element.name!r}] must be a ContactEnergyLaw; got {type(law).__name__}")
        if len(law.normal_stiffness) != len(element.ids):
            raise RvtoolInputError(f"laws[{element.name!r}] has {len(law.normal_stiffness)} contacts; the element "
                                   f"has {len(element.ids)}")
        self.anchor = law.friction_model == ref.FRICTION_ANCHOR
        self.regularized = law.friction_model == ref.FRICTION_REGULARIZED
        if self.anchor.any() and not hasattr(element.evaluator.history, "slip_distance"):
            raise RvtoolInputError(f"contact family {element.name!r} has anchor contacts but its history records "
                                   "no slip_distance; the friction dissipation cannot be attributed")
        self.element = element
        self.law = law
        self.name = element.name

    def sample(self, obs):
        obs = np.asarray(obs, np.float64)
        delta, fe, v_n, v_t = self.law.split(obs)
        slip = (np.array(self.element.evaluator.history.slip_distance, np.float64) if self.anchor.any()
                else np.zeros(len(delta)))
        return {"delta": delta, "f_damp": obs[:, ref.O_FN] - fe, "ft": obs[:, ref.O_FT], "vt": obs[:, ref.O_VT],
                "slip": slip, "V_normal": float(v_n.sum()), "V_tangential": float(v_t.sum())}

    def increments(self, a, b, dt):
        """(friction, damping) dissipation [J] between samples a and b."""
        damping = float(np.sum(0.5 * (a["f_damp"] + b["f_damp"]) * (b["delta"] - a["delta"])))
        anchor = 0.5 * (np.abs(a["ft"]) + np.abs(b["ft"])) * (b["slip"] - a["slip"])
        regularized = -0.5 * (a["ft"] * a["vt"] + b["ft"] * b["vt"]) * dt
        friction = float(np.sum(np.where(self.anchor, anchor, 0.0)) + np.sum(np.where(self.regularized, regularized, 0.0)))
        return friction, damping


def _marker_coordinate(mbs, marker):
    """Global ODE2 index of a ``NodeCoordinate`` marker, or -1 for a ground coordinate."""
    m = mbs.GetMarker(marker)
    if m["markerType"] != "NodeCoordinate":
        raise RvtoolInputError(f"marker {marker} is a {m['markerType']} marker; the energy account supports "
                               "NodeCoordinate markers on coordinate connectors and loads")
    ltg = list(mbs.systemData.GetNodeLTGODE2(m["nodeNumber"]))
    return int(ltg[m["coordinate"]]) if ltg else -1


def _gather(q, idx):
    """q[idx] with 0 where idx = -1 (ground coordinates do not move)."""
    return np.where(idx >= 0, q[np.maximum(idx, 0)], 0.0)


class EnergyAccount:
    """Energy balance of one run of ``mbs`` (see module docstring).

    mbs: the Exudyn MainSystem; elements: the contact elements passed to
    :func:`rvtool.solver.simulate` (their ``GenericODE2`` objects are
    accounted per contact family); laws: ``{element name: ContactEnergyLaw}``
    for families that are not circle-pair sets.

    The item scan runs on construction (unsupported items raise
    :class:`RvtoolInputError`); coordinate indices are resolved at
    :meth:`start`, when the system is assembled. Spring, load and constraint
    values are read at every sample, so a parameter changed between steps
    (a protocol's load level) enters at the sample where it is first seen.
    """

    def __init__(self, mbs, elements=(), *, laws=None):
        laws = dict(laws or {})
        self.mbs = mbs
        by_object = {int(e.object_number): e for e in elements}
        unknown = sorted(set(laws) - {e.name for e in elements})
        if unknown:
            raise RvtoolInputError(f"laws names {unknown}, which are not among the elements {[e.name for e in elements]}")
        self.families = [_Family(e, laws.get(e.name)) for e in elements]
        self._masses, self._structures, self._constraints, self._springs = [], [], [], []
        bad = []
        for i in range(mbs.systemData.NumberOfObjects()):
            d = mbs.GetObject(i)
            kind = d["objectType"]
            if kind not in SUPPORTED_OBJECT_TYPES:
                bad.append(f"object {i} ({kind})")
            elif kind in MASS_TYPES:
                if kind == "RigidBody2D" and np.any(np.asarray(d.get("centerOfMass", (0.0, 0.0))) != 0):
                    bad.append(f"object {i} (RigidBody2D with an offset centre of mass)")
                self._masses.append((i, kind, d))
            elif kind == "GenericODE2":
                if i in by_object:
                    continue
                if d["forceUserFunction"] != 0 or d["massMatrixUserFunction"] != 0:
                    bad.append(f"object {i} (GenericODE2 with user functions, not a contact element)")
                else:
                    self._structures.append(i)
            elif kind == "ConnectorCoordinate":
                if d.get("velocityLevel", False):
                    bad.append(f"object {i} (CoordinateConstraint at velocity level)")
                self._constraints.append(i)
            elif kind == "ConnectorCoordinateSpringDamper":
                if d["springForceUserFunction"] != 0:
                    bad.append(f"object {i} (CoordinateSpringDamper with a force user function)")
                self._springs.append(i)
        self._loads = []
        for i in range(mbs.systemData.NumberOfLoads()):
            d = mbs.GetLoad(i)
            if d["loadType"] not in SUPPORTED_LOAD_TYPES:
                bad.append(f"load {i} ({d['loadType']})")
            self._loads.append(i)
        if bad:
            raise RvtoolInputError(f"the energy account cannot attribute the energy of {bad}; supported objects: "
                                   f"{list(SUPPORTED_OBJECT_TYPES)} and contact elements, loads: "
                                   f"{list(SUPPORTED_LOAD_TYPES)}")
        self._resolved = False
        self._prev = None
        self._start = None
        self.steps = 0
        self.drive_work = 0.0
        self.load_work = 0.0
        self.spring_damping = 0.0
        self.structural_damping = 0.0
        self.friction = {f.name: 0.0 for f in self.families}
        self.contact_damping = {f.name: 0.0 for f in self.families}

    # -- set-up ------------------------------------------------------------
    def _resolve(self):
        mbs, sd = self.mbs, self.mbs.systemData
        n = sd.ODE2Size()
        self._n = n
        mass = np.zeros(n)
        for i, kind, d in self._masses:
            ltg = np.asarray(sd.GetNodeLTGODE2(d["nodeNumber"]), int)
            m = d.get("mass", d.get("physicsMass"))
            if kind == "RigidBody2D":
                mass[ltg] += (m, m, d.get("inertia", d.get("physicsInertia")))
            else:
                mass[ltg] += m
        self._mass = mass
        self._struct = []
        for i in self._structures:
            d = mbs.GetObject(i)
            ltg = np.asarray(sd.GetObjectLTGODE2(i), int)
            mats = []
            for key in ("massMatrix", "stiffnessMatrix", "dampingMatrix"):
                m = d[key]
                a = np.asarray(m.Convert2DenseMatrix() if hasattr(m, "Convert2DenseMatrix") else m, np.float64)
                mats.append(a if a.size else None)
            K = mats[1]
            if K is not None and np.abs(K - K.T).max() > STIFFNESS_SYMMETRY_TOL * max(np.abs(K).max(), 1e-300):
                raise RvtoolInputError(f"object {i}: stiffnessMatrix is not symmetric (relative asymmetry above "
                                       f"{STIFFNESS_SYMMETRY_TOL}); 1/2 q^T K q is then no potential")
            f = np.asarray(d["forceVector"], np.float64)
            self._struct.append((ltg, *mats, f if f.size else None))
        c = self._constraints
        self._c_ae = np.array([sd.GetObjectLTGAE(i)[0] for i in c], int)
        self._c_idx = np.array([[_marker_coordinate(mbs, m) for m in mbs.GetObject(i)["markerNumbers"]] for i in c],
                               int).reshape(-1, 2)
        self._c_factor = np.array([mbs.GetObject(i).get("factorValue1", 1.0) for i in c], np.float64)
        self._c_names = [mbs.GetObject(i)["name"] for i in c]
        self._s_idx = np.array([[_marker_coordinate(mbs, m) for m in mbs.GetObject(i)["markerNumbers"]]
                                for i in self._springs], int).reshape(-1, 2)
        self._l_idx = np.array([_marker_coordinate(mbs, mbs.GetLoad(i)["markerNumber"]) for i in self._loads], int)
        self.drive_by_constraint = {name: 0.0 for name in self._c_names}
        self._resolved = True

    # -- sampling ------------------------------------------------------------
    def _sample(self, t, q, v, obs):
        mbs = self.mbs
        q = np.asarray(q, np.float64)
        v = np.asarray(v, np.float64)
        s = {"t": float(t), "q": q}
        T = 0.5 * float(np.dot(self._mass * v, v))
        V_struct, struct_damp, load = 0.0, [], np.zeros(self._n)
        for ltg, M, K, D, f in self._struct:
            qs, vs = q[ltg], v[ltg]
            if M is not None:
                T += 0.5 * float(vs @ M @ vs)
            if K is not None:
                V_struct += 0.5 * float(qs @ K @ qs)
            struct_damp.append(D @ vs if D is not None else np.zeros(len(ltg)))
            if f is not None:
                load[ltg] += f
        s["T"], s["V_structure"], s["struct_damp"] = T, V_struct, struct_damp
        if self._loads:
            values = np.array([float(np.sum(mbs.GetLoadValues(i))) for i in self._loads])
            keep = self._l_idx >= 0
            np.add.at(load, self._l_idx[keep], values[keep])
        s["load"] = load
        if self._constraints:
            lam = np.asarray(mbs.systemData.GetAECoordinates(), np.float64)[self._c_ae]
            s["reaction"] = np.column_stack([lam, -self._c_factor * lam])  # -C_q^T lambda on (q_m0, q_m1)
        if self._springs:
            pars = [(mbs.GetObjectParameter(i, "stiffness"), mbs.GetObjectParameter(i, "damping"),
                     mbs.GetObjectParameter(i, "offset")) for i in self._springs]
            k, d, off = np.array(pars, np.float64).T
            ext = _gather(q, self._s_idx[:, 1]) - _gather(q, self._s_idx[:, 0])
            rate = _gather(v, self._s_idx[:, 1]) - _gather(v, self._s_idx[:, 0])
            s["spring_ext"], s["spring_damp"] = ext, d * rate
            s["V_springs"] = float(np.sum(0.5 * k * (ext - off) ** 2))
        else:
            s["V_springs"] = 0.0
        s["families"] = [f.sample(o) for f, o in zip(self.families, obs)]
        return s

    def _observations_now(self, t, q, v):
        """Observation rows of every family at the current state (read-only trial evaluation)."""
        return [f.element.evaluate(t, f.element.local(q), f.element.local(v)).obs for f in self.families]

    def start(self, t, q, v):
        """Sample the initial state (the driver calls this at Exudyn's initial step, t = t_0)."""
        if not self._resolved:
            self._resolve()
        self._start = self._prev = self._sample(t, q, v, self._observations_now(t, q, v))

    def accept(self, t, q, v):
        """Sample an accepted state after its history commit and integrate the step's work terms."""
        if self._prev is None:
            raise RvtoolInputError("EnergyAccount.accept called before start(); the driver starts the account at t_0")
        b = self._sample(t, q, v, [f.element.last_obs for f in self.families])
        a = self._prev
        dq = b["q"] - a["q"]
        self.load_work += float(np.dot(0.5 * (a["load"] + b["load"]), dq))
        if self._constraints:
            dqc = np.column_stack([_gather(dq, self._c_idx[:, 0]), _gather(dq, self._c_idx[:, 1])])
            w = np.sum(0.5 * (a["reaction"] + b["reaction"]) * dqc, axis=1)
            self.drive_work += float(w.sum())
            for name, wi in zip(self._c_names, w):
                self.drive_by_constraint[name] += float(wi)
        if self._springs:
            self.spring_damping += float(np.sum(0.5 * (a["spring_damp"] + b["spring_damp"])
                                                * (b["spring_ext"] - a["spring_ext"])))
        for (ltg, *_), da, db in zip(self._struct, a["struct_damp"], b["struct_damp"]):
            self.structural_damping += float(np.dot(0.5 * (da + db), dq[ltg]))
        dt = b["t"] - a["t"]
        for fam, fa, fb in zip(self.families, a["families"], b["families"]):
            friction, damping = fam.increments(fa, fb, dt)
            self.friction[fam.name] += friction
            self.contact_damping[fam.name] += damping
        self._prev = b
        self.steps += 1

    # -- results -------------------------------------------------------------
    @staticmethod
    def _elastic(s, families):
        terms = {"springs": s["V_springs"], "structure": s["V_structure"]}
        for fam, fs in zip(families, s["families"]):
            terms[f"contact_normal/{fam.name}"] = fs["V_normal"]
            terms[f"contact_tangential/{fam.name}"] = fs["V_tangential"]
        return terms

    def results(self):
        """The balance as a dict of floats [J] (``balance_residual_J`` = r of the module docstring)."""
        if self._start is None:
            raise RvtoolInputError("EnergyAccount.results called before start(); no state was sampled")
        a, b = self._start, self._prev
        Va, Vb = self._elastic(a, self.families), self._elastic(b, self.families)
        damping = {"springs": self.spring_damping, "structure": self.structural_damping,
                   **{f"contact/{k}": v for k, v in self.contact_damping.items()}}
        D_f, D_d = sum(self.friction.values()), sum(damping.values())
        dT, dV = b["T"] - a["T"], sum(Vb.values()) - sum(Va.values())
        residual = self.drive_work + self.load_work - dT - dV - D_f - D_d
        scale = max(abs(self.drive_work) + abs(self.load_work), a["T"] + sum(Va.values()), b["T"] + sum(Vb.values()))
        return {
            "accepted_steps": self.steps,
            "drive_work_J": self.drive_work, "drive_work_by_constraint_J": dict(self.drive_by_constraint),
            "load_work_J": self.load_work,
            "kinetic_start_J": a["T"], "kinetic_end_J": b["T"],
            "elastic_start_J": Va, "elastic_end_J": Vb,
            "friction_dissipation_J": dict(self.friction), "friction_dissipation_total_J": D_f,
            "damping_dissipation_J": damping, "damping_dissipation_total_J": D_d,
            "balance_residual_J": residual,
            "balance_rel_err": abs(residual) / scale if scale > 0 else 0.0,
            "balance_scale_J": scale,
        }
