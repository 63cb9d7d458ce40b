"""Modes of a reducer with floating flexible wheels, linearized at a static state (issue 33, target
"the mounted flexible wheel (contacts linearized at the rated torque) against a full FE of the
same assembly: first modes within 1 %").

Both models share the static state q (the reduced model's equilibrium at the load), the contact
laws' tangents J_b of every family on its bodies (rigid and virtual) and the port operators; they
differ only in how a wheel's elastic field e is represented:

* **mounted (reduced)**: the wheel's frame coordinates (x, y, theta) and its n retained in-plane
  free-free modes, e = Phi zeta (what the dynamic runs integrate);
* **full FE**: every coordinate u of the wheel's mesh, the frame motion being a sparse fit B u
  (x, y the bore's mean translation, theta the profile stations' mean rotation) and
  e = (I - R_rig B) u (a sparse split; in the linear model the frame choice only moves
  the geometric terms of the contact forces, of relative size F / (k_contact r) ~ 1e-4, between
  frame and field: the material points move by u either way).

Each family's virtual bodies are x_v = x_base + s [R(theta_w) A_v e ; a_v e] with A_v the port
operator on the FE coordinates (:class:`rvtool.assembly.flexible_wheels.PortFamily`); its tangent
contributes C_l^T (-J_b) C with C = d[x_rigid; x_v]/dX from the measuring operators and C_l from
the loading ones (the same truncations as the element: the
locator's dependence on the state and the geometric term are left out in both). The mass is the
mesh's: the frame's rigid mass and inertia R_rig^T M R_rig and the identity on zeta (reduced), M
on u (full). The regularization springs act on the frames (B u in the full model). Eigenvalues of
(K, M) over the free coordinates (the drive and the locks held): the reduced by dense ``eig``,
the full by shift-invert Lanczos on the sparse symmetric part (the asymmetry is reported).

The checks the flexible-body cases share (``cases/cycloid/flexible_wheels.py``,
``cases/rv/flexible_bodies.py``; they hand in built models, never a design):
:func:`te_and_states` and :func:`frozen_differences` (frozen modal coordinates = the rigid model),
:func:`mode_comparison` (mounted against full FE per basis), :func:`driven_run` and
:func:`driven_cost` (a driven run and its cost against the rigid one), :func:`spectrum_convergence`
(the dynamic TE spectrum against the retained modes) and :func:`spectra_and_markers` /
:func:`draw_spectra` (spectra with the mesh, bearing and body-mode markers).
"""
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import RvtoolInputError
from ..model.reducer import COORDINATES
from ..units import ARCSEC_PER_RAD


def system_mass(model):
    """Exudyn's system mass matrix (n, n) of ``model`` (dense; the builder's rigid inertia)."""
    import exudyn as exu
    solver = exu.MainSolverImplicitSecondOrder()
    ss = exu.SimulationSettings()
    ss.linearSolver.solverType = exu.LinearSolverType.EigenDense
    solver.InitializeSolver(model.mbs, ss)
    solver.ComputeMassMatrix(model.mbs)
    return np.asarray(solver.GetSystemMassMatrix(), float)


def element_modes(model, q, n=12):
    """Frequencies [Hz] of the n lowest modes of the built model linearized at q, from the contact
    elements' own contracted tangents (:func:`rvtool.protocols.stiffness.assembled_stiffness`) and
    Exudyn's mass matrix, over the free coordinates."""
    from .stiffness import assembled_stiffness
    K = assembled_stiffness(model, q)
    M = system_mass(model)
    free = np.array(sorted(set(range(len(q))) - set(model.fixed_coordinates())))
    lam = sla.eigvals(K[np.ix_(free, free)], M[np.ix_(free, free)])
    return _frequencies(lam, n)


def _frequencies(lam, n):
    lam = np.sort(np.real(np.asarray(lam)))
    lam = lam[np.isfinite(lam)]
    return np.sqrt(np.maximum(lam[:n], 0.0)) / (2 * np.pi)


def _rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]]), np.array([[-s, -c], [c, -s]])


class _Layout:
    """The coordinates X of one linear model: the rigid coordinates of the non-wheel bodies (3 per
    body), then per wheel its block (reduced: 3 frame + m modal; full: n_fe mesh coordinates).
    ``rigid(b)`` (3, n_X) and ``elastic(k)`` (n_fe, n_X) map X to a body's planar coordinates and a
    wheel's elastic field."""

    def __init__(self, model, full):
        fw = model.flexible
        self.nb = len(model.body_names)
        self.wheels = list(fw.frames)
        self.full = full
        self.ops = fw.operators
        self.models = [m.model for m in fw.meshes]
        self.Phi = [b.basis for b in fw.bodies]
        self.n_fe = [P.shape[0] for P in self.Phi]
        self.m = [P.shape[1] for P in self.Phi]
        self.start, n = {}, 0
        for b in range(self.nb):
            if b not in self.wheels:
                self.start[b] = n
                n += 3
        for k, b in enumerate(self.wheels):
            self.start[b] = n
            n += self.n_fe[k] if full else 3 + self.m[k]
        self.n = n
        self._E = {}

    def size(self, k):
        return self.n_fe[k] if self.full else 3 + self.m[k]

    def rigid(self, b):
        out = sp.lil_matrix((3, self.n))
        s = self.start[b]
        if b in self.wheels and self.full:
            k = self.wheels.index(b)
            out[:, s:s + self.n_fe[k]] = self.fit(k)
        else:
            out[:, s:s + 3] = np.eye(3)
        return out.tocsr()

    def fit(self, k):
        """(3, n_fe) sparse: the full model's frame of wheel k, x and y the bore's mean translation
        (a wheel without a central bore, the RV's: the mean translation of its holes, the crank
        bores), theta the mean rotation of the profile stations about the centre (sparse rows)."""
        if k not in self._E:
            ops = self.ops[k]
            m = self.models[k]
            pos = m.vertices[m.dof_vertex, np.minimum(m.dof_component, 1)]
            P = ops.profile
            x, y = P[0::2] @ pos, P[1::2] @ pos
            r2 = x * x + y * y
            theta = (sp.diags(-y / r2) @ P[0::2] + sp.diags(x / r2) @ P[1::2]).mean(axis=0)
            if ops.bore is not None:
                xy = ops.bore[:2]
            else:
                nh = ops.holes.shape[0] // 2
                avg = sp.csr_matrix(np.full((1, nh), 1.0 / nh))
                xy = sp.vstack([avg @ ops.holes[0::2], avg @ ops.holes[1::2]])
            self._E[k] = sp.vstack([sp.csr_matrix(xy), sp.csr_matrix(theta)]).tocsr()
        return self._E[k]

    def elastic_of(self, k, A):
        """A e_k as a sparse (rows, n_X) map: A (rows, n_fe) applied to wheel k's elastic field
        (full: A (I - R_rig B) u = A u - (A R_rig) B u; reduced: A Phi zeta)."""
        b = self.wheels[k]
        s = self.start[b]
        A = sp.csr_matrix(A)
        if self.full:
            blk = A - sp.csr_matrix(A @ self.ops[k].rigid) @ self.fit(k)
        else:
            blk = sp.hstack([sp.csr_matrix((A.shape[0], 3)), sp.csr_matrix(A @ self.Phi[k])])
        w = blk.shape[1]
        return sp.hstack([sp.csr_matrix((A.shape[0], s)), blk, sp.csr_matrix((A.shape[0], self.n - s - w))]).tocsr()


def linear_model(model, q, *, full):
    """(K, M, free) of the mounted (``full=False``) or full-FE (``full=True``) linear model at the
    static state q (module docstring); K and M sparse over X, free: the indices of X not held."""
    fw = model.flexible
    if fw is None:
        raise RvtoolInputError("the model has no flexible wheels (wheels.dynamics.model = 'flexible')")
    if "wheels" not in model.structures:
        raise RvtoolInputError("the mounted-mode comparison of flexible wheels with other flexible bodies (flexible "
                               "cranks too) is not implemented; valid: cranks.dynamics.model = 'rigid'")
    L = _Layout(model, full)
    nb = L.nb
    zeta_idx = model.structures["wheels"].coordinate_indices()
    pose = np.array([model.body_pose(q, b) for b in range(nb)])
    e_star = [fw.bodies[k].basis @ q[zeta_idx][fw.coordinates.slice(f"wheel{k}")] for k in range(fw.nw)]
    rigid_rows = sp.vstack([L.rigid(b) for b in range(nb)]).tocsr()          # (3 nb, n)
    K = sp.csr_matrix((L.n, L.n))
    asym = 0.0

    def virtual_rows(fam, A):
        rows = []
        for i in range(len(fam.base)):
            k, f, sg = int(fam.wheel[i]), int(fam.frame[i]), float(fam.sign[i])
            R, dR = _rot(pose[f, 2])
            r = L.elastic_of(k, np.vstack([R @ A[i][:2], A[i][2:3]])) * sg
            r = r + sp.csr_matrix(np.vstack([(dR @ (A[i][:2] @ e_star[k]))[:, None], [[0.0]]])) @ L.rigid(f)[2:3] * sg
            if fam.base[i] >= 0:
                r = r + L.rigid(int(fam.base[i]))
            rows.append(r)
        return sp.vstack([rigid_rows] + rows).tocsr()
    for name, el in model.elements.items():
        ql = np.asarray(el.local(q), float)
        p, v = el.pose_velocity(ql, np.zeros(len(ql)))
        J = el.evaluator.evaluate(p, v, check=False).dQdq
        if el.ports is None:
            C = Cl = rigid_rows
        else:
            fam = fw.families[name]
            C = virtual_rows(fam, fam.operator(pose))
            Cl = virtual_rows(fam, fam.operator(pose, True)) if any(o.split for o in fw.operators) else C
        asym = max(asym, abs(J - J.T).max() / max(abs(J).max(), 1e-300))
        K = K + Cl.T @ sp.csr_matrix(-J) @ C
    # the structures' own stiffness
    for k in range(fw.nw):
        s = L.start[L.wheels[k]]
        if full:
            K = K + _embed(fw.meshes[k].model.elastic_stiffness, s, L.n)
        else:
            K = K + _embed(sp.diags(fw.bodies[k].omega2), s + 3, L.n)
    # regularization springs on the bodies' planar coordinates
    glob = {model.coordinate_index(b, c): (b, c) for b in range(nb) for c in range(3)}
    for i, kk in model.regularization_stiffness():
        if i in glob:
            b, c = glob[i]
            row = L.rigid(b)[c]
            K = K + kk * (row.T @ row)
    # mass: non-wheel bodies from Exudyn's matrix, wheels from the mesh
    Mx = system_mass(model)
    M = sp.lil_matrix((L.n, L.n))
    for b in range(nb):
        if b in L.wheels:
            continue
        g = [model.coordinate_index(b, c) for c in range(3)]
        s = L.start[b]
        M[s:s + 3, s:s + 3] = Mx[np.ix_(g, g)]
    M = M.tocsr()
    for k, b in enumerate(L.wheels):
        s = L.start[b]
        mass = fw.meshes[k].model.mass
        if full:
            M = M + _embed(mass, s, L.n)
        else:
            Rr = L.ops[k].rigid
            Mr = np.zeros((3 + L.m[k], 3 + L.m[k]))
            Mr[:3, :3] = Rr.T @ (mass @ Rr)
            Mr[3:, 3:] = np.eye(L.m[k])
            M = M + _embed(sp.csr_matrix(Mr), s, L.n)
    # held coordinates: the drive and the locks on non-wheel bodies (a lock on a wheel is refused)
    held = []
    for i in model.fixed_coordinates():
        if i in glob:
            b, c = glob[i]
            if b in L.wheels:
                raise RvtoolInputError(f"wheel coordinate {COORDINATES[c]} of body {b} is locked; the full-FE model "
                                       "keeps every wheel coordinate free (valid: bodies.wheel = ['x', 'y', 'theta'])")
            held.append(L.start[b] + c)
    free = np.setdiff1d(np.arange(L.n), held)
    return K.tocsr(), M.tocsr(), free, asym


def _embed(A, s, n):
    A = sp.csr_matrix(A)
    k = A.shape[0]
    return sp.bmat([[sp.csr_matrix((s, s)), None, None], [None, A, None],
                    [None, None, sp.csr_matrix((n - s - k, n - s - k))]], format="csr") if n - s - k > 0 else \
        sp.bmat([[sp.csr_matrix((s, s)), None], [None, A]], format="csr")


def mounted_modes(model, q, *, n=12, full=False):
    """dict(frequencies_hz (n,), asymmetry, in_plane (n,)): the n lowest in-plane modes of the
    mounted reduced model or of the full FE of the same assembly, linearized at q (module
    docstring). Both use the symmetric part of K (``asymmetry``: the largest relative asymmetry of
    a family's contact tangent). The full mesh also has the wheel's out-of-plane motion (rigid z
    translation and tilts, which no planar contact holds, and plate modes): modes with less than
    half their kinetic energy in the plane are left out, as in the choice of the retained modes
    (:data:`rvtool.structure.floating_ports.IN_PLANE_FRACTION`)."""
    from ..structure.floating_ports import IN_PLANE_FRACTION
    K, M, free, asym = linear_model(model, q, full=full)
    Kf, Mf = K[free][:, free], M[free][:, free]
    Ks = 0.5 * (Kf + Kf.T)
    if not full:
        lam = sla.eigh(Ks.toarray(), Mf.toarray(), eigvals_only=True)
        return {"frequencies_hz": _frequencies(lam, n), "asymmetry": asym, "in_plane": np.ones(n)}
    fw = model.flexible
    L = _Layout(model, True)
    z = np.zeros(L.n, bool)
    for k, b in enumerate(L.wheels):
        z[L.start[b]:L.start[b] + L.n_fe[k]] = fw.meshes[k].model.dof_component == 2
    zf = z[free]
    k = 3 * n + 12
    # shift at half the reduced model's lowest eigenvalue (Rayleigh-Ritz: above none of the full model's
    # in-plane modes it is compared with, and near them): a shift at -1 leaves the out-of-plane rigid modes
    # (eigenvalue 0) dominating the inverted operator by 1 / lambda_1 ~ 1e-8, and the factorization's
    # round-off then moved the full model's frequencies by up to ~0.5 % between runs (random start vector);
    # the start vector is fixed, so repeated runs agree
    Kr, Mr, fr, _ = linear_model(model, q, full=False)
    lam_r = sla.eigh((0.5 * (Kr[fr][:, fr] + Kr[fr][:, fr].T)).toarray(), Mr[fr][:, fr].toarray(), eigvals_only=True)
    sigma = 0.5 * float(lam_r[lam_r > 0][0])
    # the shift-invert factorization with a minimum-degree ordering of A + A^T (A is symmetric): on RD-40's
    # coarse wheels 26 s and 26 M entries in L + U, each solve 0.09 s, against 33 s, 54 M and 0.24 s with
    # eigsh's own (COLAMD), the contacts coupling every profile coordinate of a wheel
    lu = spla.splu((Ks - sigma * Mf).tocsc(), permc_spec="MMD_AT_PLUS_A")
    op = spla.LinearOperator(Ks.shape, matvec=lu.solve, dtype=float)
    lam, vec = spla.eigsh(Ks.tocsc(), k=k, M=Mf.tocsc(), sigma=sigma, OPinv=op, which="LM", v0=np.ones(Ks.shape[0]))
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    Mv = Mf @ vec
    total = np.einsum("ij,ij->j", vec, Mv)
    vz = np.where(zf[:, None], vec, 0.0)
    frac = 1.0 - np.einsum("ij,ij->j", vz, Mf @ vz) / total
    keep = np.flatnonzero(frac >= IN_PLANE_FRACTION)[:n]
    if len(keep) < n:
        raise RvtoolInputError(f"only {len(keep)} in-plane modes among the {k} lowest of the full model; valid: n <= "
                               f"{len(keep)}")
    return {"frequencies_hz": _frequencies(lam[keep], n), "asymmetry": asym, "in_plane": frac[keep]}


def crank_linear_model(model, q, *, full=False):
    """(K, M, free, asymmetry) of the RV model with flexible cranks (``cranks.dynamics.model =
    "flexible"``, :mod:`rvtool.assembly.rv.flexible_cranks`) linearized at the static state q,
    every crank's elastic field on a basis B: its retained basis (``full=False``: the mounted
    reduced model the dynamic runs integrate) or every elastic mode of its beam FE (``full=True``:
    the full FE of the same assembly, the crank beam's every coordinate less its five rigid
    modes; the frame holds the tilts as the planar crank does).

    Coordinates X: 3 per body (the cranks' frames included), then per crank the coordinates on B.
    Each family on the cranks contributes C^T (-J_b) C, with J_b the contact law's tangent over
    [rigid bodies; virtual bodies] and C = d[x_rigid; x_v]/dX: a virtual body's row is its base's
    plus R(theta) S_v B on its crank's block (S_v the station operators on the beam's FE
    coordinates) plus the frame-rotation term dR S_v e* (e* the elastic field at q). The beam
    block is diag(omega^2) and its mass the identity (B is M-orthonormal and K-diagonal); the
    bodies' mass is Exudyn's; the regularization springs act on the frames."""
    fc = model.flexible_cranks
    if fc is None:
        raise RvtoolInputError("the model has no flexible cranks (cranks.dynamics.model = 'flexible')")
    if "cranks" not in model.structures:
        raise RvtoolInputError("the mode comparison of flexible cranks with flexible wheels too is not implemented; "
                               "valid: wheels.dynamics.model = 'rigid'")
    nb = len(model.body_names)
    body = fc.full_body() if full else fc.body
    beam = fc.body.beam
    B = body.basis
    m = B.shape[1]
    n = 3 * nb + fc.nc * m
    zeta_idx = model.structures["cranks"].coordinate_indices()
    pose = np.array([model.body_pose(q, b) for b in range(nb)])
    e_star = [fc.body.basis @ q[zeta_idx][fc.coordinates.slice(f"crank{k}")] for k in range(fc.nc)]
    R3 = np.zeros((3 * nb, n))
    R3[:, :3 * nb] = np.eye(3 * nb)
    K = np.zeros((n, n))
    asym = 0.0
    for name, el in model.elements.items():
        ql = np.asarray(el.local(q), float)
        p, v = el.pose_velocity(ql, np.zeros(len(ql)))
        J = np.asarray(el.evaluator.evaluate(p, v, check=False).dQdq, float)
        if el.ports is None:
            C = R3
        else:
            fam = fc.families[name]
            S = fam.operator(beam)                                   # (n_v, 3, n_fe)
            rows = []
            for i in range(len(fam.frame)):
                k, f = int(fam.crank[i]), int(fam.frame[i])
                Rm, dR = _rot(pose[f, 2])
                r = np.zeros((3, n))
                r[:, 3 * f:3 * f + 3] = np.eye(3)                    # base = frame: the crank itself
                blk = slice(3 * nb + k * m, 3 * nb + (k + 1) * m)
                r[:2, blk] = Rm @ (S[i][:2] @ B)
                r[2, blk] = S[i][2] @ B
                r[:2, 3 * f + 2] += dR @ (S[i][:2] @ e_star[k])
                rows.append(r)
            C = np.vstack([R3] + rows)
        asym = max(asym, np.abs(J - J.T).max() / max(np.abs(J).max(), 1e-300))
        K += C.T @ (-J) @ C
    for k in range(fc.nc):
        s = 3 * nb + k * m
        K[s:s + m, s:s + m] += np.diag(body.omega2)
    glob = {model.coordinate_index(b, c): (b, c) for b in range(nb) for c in range(3)}
    for i, kk in model.regularization_stiffness():
        if i in glob:
            b, c = glob[i]
            K[3 * b + c, 3 * b + c] += kk
    Mx = system_mass(model)
    M = np.zeros((n, n))
    g = [model.coordinate_index(b, c) for b in range(nb) for c in range(3)]
    M[:3 * nb, :3 * nb] = Mx[np.ix_(g, g)]
    M[3 * nb:, 3 * nb:] = np.eye(fc.nc * m)
    held = [3 * glob[i][0] + glob[i][1] for i in model.fixed_coordinates() if i in glob]
    free = np.setdiff1d(np.arange(n), held)
    return K, M, free, asym


def crank_modes(model, q, *, n=12, full=False):
    """dict(frequencies_hz (n,), asymmetry, n_coordinates): the n lowest modes of the RV model with
    flexible cranks linearized at q, mounted (reduced) or with every elastic mode of the crank beam
    (``full``; :func:`crank_linear_model`), from the symmetric part of K."""
    K, M, free, asym = crank_linear_model(model, q, full=full)
    Kf, Mf = K[np.ix_(free, free)], M[np.ix_(free, free)]
    lam = sla.eigh(0.5 * (Kf + Kf.T), Mf, eigvals_only=True)
    return {"frequencies_hz": _frequencies(lam, n), "asymmetry": asym, "n_coordinates": int(len(free))}


# -- checks the flexible-body cases share ---------------------------------------------------------
DRIVEN_ABS_TOL = 1e-6
"""Absolute tolerance of the driven runs' steps (as ``cases/cycloid/vibration.py``) [N, N m]."""


def te_and_states(model, torque, angles):
    """(TE [rad] (n,), body displacements (n, nb, 3)) of the quasi-static sequence of ``model`` at
    output ``torque`` [N m] over input ``angles`` [rad] on the Exudyn path."""
    from .precision import quasi_static_te
    qs = []
    nb = len(model.body_names)

    def keep(k, angle, q):
        qs.append([model.body_pose(q, b) - model.reference[b] for b in range(nb)])
    te = quasi_static_te(model, torque=torque, input_angles=angles, backend="exudyn", record=keep)["te"]
    return np.asarray(te), np.asarray(qs)


def frozen_differences(rigid, frozen):
    """Largest TE difference [arcsec] and relative TE and state differences of two
    :func:`te_and_states` results, the rigid model's and the frozen flexible one's."""
    (te_r, q_r), (te_f, q_f) = rigid, frozen
    d = np.abs(te_f - te_r).max()
    return {"te_max_abs_diff_arcsec": float(d * ARCSEC_PER_RAD), "te_max_rel_diff": float(d / np.abs(te_r).max()),
            "states_max_rel_diff": float(np.abs(q_f - q_r).max() / np.abs(q_r).max())}


def mode_comparison(model_of, bases, torque, *, n, bound, default, modes=None, full=True):
    """(dict, model) of the mounted modes against the full FE of the same assembly for every basis
    (n_modes, static_orders) in ``bases``: ``model_of(n_modes, static_orders)`` a built model, loaded
    to output ``torque`` [N m] at input angle 0 by continuation; ``modes`` :func:`mounted_modes`
    (default) or :func:`crank_modes`, each giving the ``n`` lowest. The dict holds per basis the
    reduced frequencies [Hz] and the largest contact tangent asymmetry; with ``full`` also the full
    FE's frequencies, the relative differences, and for the ``default`` basis the largest difference,
    how many modes lie within ``bound`` (relative) and whether all do (``full=False``: the mounted
    modes alone, without the full FE's shift-invert solve). ``model`` is the last basis's."""
    from ..solver.continuation import Continuation
    modes = modes or mounted_modes
    out = {"bases": [list(b) for b in bases], "reduced_hz": [], "contact_tangent_asymmetry": 0.0, "full_fe": bool(full)}
    if full:
        out.update(full_hz=[], rel_diff=[])
    for basis in bases:
        m = model_of(*basis)
        q = Continuation(m, input_angle=0.0).go_to(-np.sign(m.ratio) * torque)
        red = modes(m, q, n=n)
        out["reduced_hz"].append(red["frequencies_hz"].tolist())
        out["contact_tangent_asymmetry"] = max(out["contact_tangent_asymmetry"], red["asymmetry"])
        if not full:
            continue
        ful = modes(m, q, n=n, full=True)
        out["full_hz"].append(ful["frequencies_hz"].tolist())
        out["rel_diff"].append((red["frequencies_hz"] / ful["frequencies_hz"] - 1).tolist())
        if "n_coordinates" in ful:
            out["full_coordinates"] = ful["n_coordinates"]
    if full:
        worst = np.abs(out["rel_diff"][list(bases).index(tuple(default))])
        out["max_rel_diff_default_basis"] = float(worst.max())
        out["modes_within_target_default_basis"] = int(np.argmax(worst > bound)) if np.any(worst > bound) \
            else len(worst)
        out["target_rel"] = bound
        out["target_met"] = bool(worst.max() <= bound)
        # Rayleigh-Ritz: every reduced frequency at or above the full FE's (round-off 1e-9), and the full
        # shift-invert solve repeatable bit for bit (fixed shift and start vector: the former shift at -1 with a
        # random start moved frequencies by up to 0.5 % between solves); on the default basis's model
        k = list(bases).index(tuple(default))
        red_d, ful_d = np.asarray(out["reduced_hz"][k]), np.asarray(out["full_hz"][k])
        out["rayleigh_min_ratio_default_basis"] = float((red_d / ful_d).min())
        if k == len(bases) - 1:
            again = modes(m, q, n=n, full=True)["frequencies_hz"]
            out["full_fe_repeat_max_rel_diff"] = float(np.abs(again / ful_d - 1).max())
    return out, m


def driven_run(model, speed_rpm, torque, revs, step, coordinates=None):
    """(run, protocol, wall_s) of a driven run of ``model`` at input speed [rpm] and output torque
    [N m] over ``revs`` input revolutions with step ``step`` [s] (:func:`rvtool.protocols.vibration.driven_response`;
    ``coordinates`` its recorded responses besides the torsion)."""
    from ..solver import RunSpec
    from .vibration import driven_response
    proto = driven_protocol(speed_rpm, torque, revs, step)
    t0 = time.perf_counter()
    run = driven_response(model, proto, RunSpec(end_time=proto.duration, step=step, abs_tol=DRIVEN_ABS_TOL,
                                                rel_tol=1e-8), coordinates=coordinates or {})
    return run, proto, time.perf_counter() - t0


def driven_protocol(speed_rpm, torque, revs, step):
    """The :class:`rvtool.protocols.vibration.VibrationProtocol` of :func:`driven_run` (its spectra's window)."""
    from .vibration import VibrationProtocol
    return VibrationProtocol(speed_rpm=speed_rpm, torque=torque, duration=revs * 60.0 / speed_rpm, sample_step=step)


def driven_cost(flexible, rigid, revs, speed_rpm, step):
    """The cost of a driven run with flexible bodies against the rigid one: ``flexible`` and
    ``rigid`` (run, wall_s) of :func:`driven_run` over ``revs`` input revolutions at ``speed_rpm``
    with ``step`` [s]. The cost of one input revolution is the integration's wall time (the run
    record's, without the loaded start's static solve), measured over a whole revolution, else
    extrapolated from the cost per accepted step (``per_revolution_extrapolated``)."""
    (run_f, wall_f), (run_r, wall_r) = flexible, rigid
    rec, rec_r = run_f["record"], run_r["record"]
    steps_per_rev = 60.0 / speed_rpm / step

    def per_revolution(r):
        return r.wall_s / revs if revs >= 1 else r.wall_s / max(r.accepted_steps, 1) * steps_per_rev
    return {
        "input_revolutions": revs, "input_revolutions_run": float(run_f["t"][-1] * speed_rpm / 60.0),
        "accepted_steps": rec.accepted_steps, "rejected_steps": rec.rejected_steps, "max_residual": rec.max_residual,
        "abs_tol": DRIVEN_ABS_TOL, "wall_s_flexible": wall_f, "wall_s_rigid": wall_r, "cost_ratio": wall_f / wall_r,
        "wall_s_per_step_flexible": wall_f / max(rec.accepted_steps, 1),
        "wall_s_per_step_rigid": wall_r / max(rec_r.accepted_steps, 1),
        "integration_wall_s_flexible": rec.wall_s, "integration_wall_s_rigid": rec_r.wall_s,
        "wall_s_per_input_revolution_flexible": per_revolution(rec),
        "wall_s_per_input_revolution_rigid": per_revolution(rec_r),
        "per_revolution_extrapolated": revs < 1,
        "torsion_pp_flexible_arcsec": float(np.ptp(run_f["responses"]["torsion"]) * ARCSEC_PER_RAD),
        "torsion_pp_rigid_arcsec": float(np.ptp(run_r["responses"]["torsion"]) * ARCSEC_PER_RAD),
    }


def spectrum_convergence(runs, protocol, response="torsion"):
    """(spectra, changes) of driven runs with growing bases over one window (``protocol``): the
    spectra of ``response`` (:func:`rvtool.protocols.vibration.vibration_spectra`) and the change of
    each to the next, max |S_(i+1) - S_i| / max S_(i+1) (the peak without the mean)."""
    from .vibration import vibration_spectra
    spectra = [vibration_spectra(r, protocol, response) for r in runs]
    return spectra, [float(np.max(np.abs(b["spectrum"] - a["spectrum"])) / np.max(b["spectrum"][1:]))
                     for a, b in zip(spectra[:-1], spectra[1:])]


def spectra_and_markers(flexible, rigid, protocol, model, speed_rpm, mounted_hz, body="wheel0_x"):
    """(spectra dict, markers, (torsion flexible, torsion rigid, body)) of the driven runs
    ``flexible`` and ``rigid`` over ``protocol``: the torsion spectra [arcsec] and the flexible run's
    ``body`` response [m]; the markers of ``model`` at ``speed_rpm`` with ``mounted_modes_hz``
    (``mounted_hz``)."""
    from . import vibration as V
    sp_f = V.vibration_spectra(flexible, protocol, "torsion")
    sp_r = V.vibration_spectra(rigid, protocol, "torsion")
    sw = V.vibration_spectra(flexible, protocol, body)
    markers = V.marker_frequencies(model, speed_rpm)
    markers["mounted_modes_hz"] = mounted_hz
    spectra = {"frequencies_hz": sp_f["frequencies_hz"], "torsion_flexible_arcsec": sp_f["spectrum"] * ARCSEC_PER_RAD,
               "torsion_rigid_arcsec": sp_r["spectrum"] * ARCSEC_PER_RAD, f"{body}_flexible_m": sw["spectrum"]}
    return spectra, markers, (sp_f, sp_r, sw)


def draw_spectra(axes, spectra, markers, *, meshes, bearings, modes=()):
    """Draw the torsion spectra (flexible and rigid) and the body response's spectrum
    (``spectra`` the triple of :func:`spectra_and_markers`) on two axes, with vertical markers:
    ``meshes`` (key, label, colour) of mesh frequencies, the BPFO of the ``bearings`` named, the
    retained and mounted modes and the further body-mode keys ``modes`` (key, label, colour)."""
    from .vibration import body_mode_markers
    sp_f, sp_r, sw = spectra
    for a, (spec, unit, scale) in zip(axes, ((sp_f, "torsion amplitude [arcsec]", ARCSEC_PER_RAD),
                                             (sw, "wheel 0 x amplitude [m]", 1.0))):
        a.semilogy(spec["frequencies_hz"][1:], spec["spectrum"][1:] * scale + 1e-15, lw=0.8, label="flexible wheels")
        if spec is sp_f:
            a.semilogy(sp_r["frequencies_hz"][1:], sp_r["spectrum"][1:] * scale + 1e-15, lw=0.6, alpha=0.7,
                       label="rigid wheels")
        for key, label, colour in meshes:
            a.axvline(markers[key], color=colour, ls="--", lw=0.8, label=label)
        for k, name in enumerate(bearings):
            if name in markers:
                a.axvline(markers[name]["bpfo"], color=f"C{k + 2}", ls=":", lw=0.8, label=f"{name} BPFO")
        body_mode_markers(a, markers)
        body_mode_markers(a, markers, key="mounted_modes_hz", label="mounted modes", color="c")
        for key, label, colour in modes:
            body_mode_markers(a, markers, key=key, label=label, color=colour)
        a.set(xlabel="frequency [Hz]", ylabel=unit)
    axes[0].legend(fontsize=6)


def wheel_criteria(r, *, n_compared, bound):
    """The checks both flexible-wheel cases make on their results ``r`` (``driven``, ``convergence``
    and ``modes`` as written from :func:`driven_cost`, :func:`spectrum_convergence` and
    :func:`mode_comparison`), each as the arguments (value, bound, op, why) of
    :func:`rvtool.casekit.check`; the full-FE comparison where ``r["modes"]`` has it."""
    e, c, modes = r["driven"], r["convergence"], r["modes"]
    out = {
        "driven_run_complete": (e["input_revolutions_run"], e["input_revolutions"] * (1 - 1e-9), ">=",
                                "the run reaches its end time (one input revolution in the full run)"),
        "driven_steps_converged": (e["max_residual"], e["abs_tol"], "<=",
                                   "every accepted step meets the run's absolute tolerance"),
        # the torsion spectrum of the two largest bases: the change is bounded by 2 % of its peak (a converged
        # basis changes the response by less than the modes it adds carry)
        "te_spectrum_converged_in_modes": (c["spectrum_change_vs_peak"][-1], 0.02, "<=",
                                           "largest two bases: spectrum change / peak"),
        "mounted_modes_positive": (min(modes["reduced_hz"][0]), 0.0, ">",
                                   "the mounted wheels at the rated torque: every free coordinate held by contacts "
                                   "or springs (no zero or unstable mode)"),
    }
    # the full FE of the mounted wheels (a shift-invert solve of ~17k coordinates with dense contact coupling,
    # about 2/3 of the former quick runs' time) runs in the cases' full runs only
    if modes.get("full_fe", True):
        out["mounted_modes_vs_full_fe"] = (modes["max_rel_diff_default_basis"], bound, "<=",
                                           f"issue 33: the first {n_compared} modes of the mounted flexible wheels "
                                           "against the full FE of the same assembly")
        out["mounted_modes_rayleigh"] = (modes["rayleigh_min_ratio_default_basis"], 1 - 1e-9, ">=",
                                         "Rayleigh-Ritz: every reduced frequency at or above the full FE's")
        if "full_fe_repeat_max_rel_diff" in modes:
            out["full_fe_repeatable"] = (modes["full_fe_repeat_max_rel_diff"], 0.0, "<=",
                                         "the full FE's shift-invert solve repeated gives the same frequencies")
    return out
