"""The RV carrier (output flange, pillars, end plate) as a reduced structure with bearing-seat ports (issue 30).

Geometry (Netgen CSG, reducer axis z, z = 0 the mid-plane between the two cycloid wheels; the output side +z):
two plates, the output flange at z in [h, h + t_f] and the end plate at z in [-h - t_e, -h] (h =
``inner_face_position``), each a disc of ``outer_radius`` with a central bore of ``bore_radius`` and one
crank-bearing seat bore of ``seat_radius`` per crank on the crank circle; the plates are joined by one pillar
between every two neighbouring cranks (through the wheels' pillar holes), ``"circular"`` (a cylinder of
``pillar_radius`` on ``pillar_circle_radius``) or ``"sector"`` (an annular sector ``pillar_circle_radius`` +-
``pillar_radius`` wide radially, ``pillar_angle`` wide). The parent is meshed with first-order tetrahedra
(:mod:`rvtool.structure.fe_model`).

Frame: the output face (z = h + t_f) is clamped. The carrier body of the reducer model *is* this face -- the
output torque is applied there and the output angle is read there -- so every port displacement is relative
to the output face.

Ports (planar: in-plane x, y), each a distributed port (an RBE3-type average, not one vertex): the
displacement of a seat is the area-weighted mean of the displacements of the surface vertices of the seat,
u_g = sum_i w_i u_i / sum_i w_i (w_i: a third of the areas of the seat's surface triangles at vertex i), and the
load f_g on the port is spread over the seat by the transpose, w_i f_g / sum w. Crank k's port is the mean of
its two seats (the bore in the flange and the bore in the end plate: the two tapered rows of its pair, the load
split equally between them); the main-bearing port is the mean of the two plates' outer cylinders (the inner
races of the two angular-contact rows). Rows: crank k at (2k, 2k + 1), the main bearing at the last two.

Reduction: the distributed ports couple hundreds of seat vertices, so a Craig--Bampton boundary of all their
coordinates would be large and dense; instead the Ritz basis is the static port modes K^-1 P^T (one per port
row) and the ``n_modes`` lowest modes of the clamped carrier, mass-orthonormalized by a Rayleigh--Ritz solve
(the basis of Eq. (port_residual_flexibility) with every port row's residual mode retained): the reduced
static port compliance H Omega^-2 H^T equals the parent's P K^-1 P^T to round-off, because the parent's static
port responses lie in the basis (Galerkin exactness). The result is a
:class:`~rvtool.structure.port_reduction.PortReducedModel`.
"""
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import RvtoolInputError
from ..units import angle_field
from ..validation import check_positive, check_range
from .fe_model import MAX_STRUCTURE_MODES, ElasticMaterial, generate_mesh
from .port_reduction import PortReducedModel

PILLAR_SHAPES = ("circular", "sector")


@dataclass(frozen=True, kw_only=True)
class CarrierStructure:
    """Parametric carrier (module docstring). Lengths [m], angles [rad].

    inner_face_position: h, the axial position of both plates' inner faces from the wheels' mid-plane [m].
    flange_thickness: t_f, the output flange's axial thickness [m]. end_plate_thickness: t_e, the end plate's
    axial thickness [m]. outer_radius: the plates' outer radius, the main bearings' inner-race seat [m].
    bore_radius: the plates' central bore radius [m]. seat_radius: the crank-bearing seat bore radius (the
    tapered rows' cup outer radius) [m]. pillar_shape: ``"circular"`` or ``"sector"``. pillar_circle_radius:
    the radius of the pillars' centres [m]. pillar_radius: a circular pillar's radius, a sector pillar's
    half radial depth [m]. pillar_angle: a sector pillar's angular width, unused by circular pillars [rad].
    material: the carrier's material (None: the design's ``[material]``).
    mesh_size: nominal tetrahedron size [m]. element_order: polynomial order of the displacement [-] (1: linear
    tetrahedra, too stiff in the plates' and pillars' bending at practical sizes; 2: quadratic on a curved mesh).
    n_modes: clamped-carrier modes kept beside the static port
    modes [-] (the static port compliance does not depend on them).
    """
    inner_face_position: float
    flange_thickness: float
    end_plate_thickness: float
    outer_radius: float
    bore_radius: float
    seat_radius: float
    pillar_shape: str = "circular"
    pillar_circle_radius: float
    pillar_radius: float
    pillar_angle: float = angle_field(math.radians(30.0))
    material: ElasticMaterial | None = None
    mesh_size: float
    element_order: int = 1
    n_modes: int = 6

    def __post_init__(self):
        for nm in ("flange_thickness", "end_plate_thickness", "bore_radius", "seat_radius", "pillar_radius"):
            check_positive(f"carrier.structure.{nm}", getattr(self, nm))
        check_range("carrier.structure.inner_face_position", self.inner_face_position, 0.0, math.inf, low_open=True)
        check_range("carrier.structure.outer_radius", self.outer_radius, self.bore_radius, math.inf, low_open=True)
        if self.pillar_shape not in PILLAR_SHAPES:
            raise RvtoolInputError(f"carrier.structure.pillar_shape = {self.pillar_shape!r}; valid choices are "
                                   f"{list(PILLAR_SHAPES)}")
        check_range("carrier.structure.pillar_angle_deg", math.degrees(self.pillar_angle), 0.0, 120.0,
                    low_open=True, high_open=True)
        check_range("carrier.structure.pillar_circle_radius", self.pillar_circle_radius,
                    self.bore_radius + self.pillar_radius, self.outer_radius - self.pillar_radius,
                    low_open=True, high_open=True)
        check_range("carrier.structure.mesh_size", self.mesh_size, 0.0,
                    min(self.flange_thickness, self.end_plate_thickness), low_open=True)
        if isinstance(self.element_order, bool) or self.element_order not in (1, 2):
            raise RvtoolInputError(f"carrier.structure.element_order = {self.element_order!r} is outside the valid "
                                   "range [1, 2] (integer)")
        # upper bound: a cost limit (fe_model.MAX_STRUCTURE_MODES: each mode an eigenpair of the sparse solve and a
        # coordinate of every Newton step), checked before the carrier is meshed
        if isinstance(self.n_modes, bool) or not isinstance(self.n_modes, int) \
                or not 0 <= self.n_modes <= MAX_STRUCTURE_MODES:
            raise RvtoolInputError(f"carrier.structure.n_modes = {self.n_modes!r} is outside the valid range "
                                   f"[0, {MAX_STRUCTURE_MODES}] (integer)")

    @property
    def output_face(self):
        """z [m] of the output face (the flange's outer face, clamped: the carrier body's frame)."""
        return self.inner_face_position + self.flange_thickness

    def plates(self):
        """((z_low, z_high) of the output flange, of the end plate) [m]."""
        h = self.inner_face_position
        return (h, h + self.flange_thickness), (-h - self.end_plate_thickness, -h)

    def check_layout(self, crank_radius, crank_angles, row_positions, main_row_positions):
        """The carrier fits the design: the crank seats inside the plates and clear of the bore, the outer
        edge and each other; the pillars clear of the seats; every tapered row (``row_positions`` [m]) and
        main-bearing row (``main_row_positions`` [m]) axially inside a plate. Raises naming the key."""
        s = "carrier.structure"
        lo = self.bore_radius + self.seat_radius
        hi = self.outer_radius - self.seat_radius
        if not lo < crank_radius < hi:
            raise RvtoolInputError(f"{s}.seat_radius = {self.seat_radius} m: the crank seats (crank circle radius "
                                   f"{crank_radius:.6g} m) must clear the bore and the outer edge; valid range "
                                   f"(0, {min(crank_radius - self.bore_radius, self.outer_radius - crank_radius):.6g})"
                                   " m")
        n = len(crank_angles)
        if 2 * crank_radius * math.sin(math.pi / n) <= 2 * self.seat_radius:
            raise RvtoolInputError(f"{s}.seat_radius = {self.seat_radius} m: neighbouring crank seats overlap; valid "
                                   f"range (0, {crank_radius * math.sin(math.pi / n):.6g}) m")
        gap = _pillar_seat_gap(self, crank_radius, crank_angles)
        if gap <= 0.0:
            raise RvtoolInputError(f"{s}.pillar_radius = {self.pillar_radius} m: the pillars cut the crank seats "
                                   f"(clearance {gap:.3g} m); valid: a smaller pillar_radius, pillar_angle_deg or "
                                   "another pillar_circle_radius")
        plates = self.plates()
        for key, zs in (("crank_bearing.row_spacing", row_positions), ("main_bearing.row_spacing", main_row_positions)):
            for z in zs:
                if not any(a <= z <= b for a, b in plates):
                    raise RvtoolInputError(f"{key}: a row at z = {z:.6g} m lies outside both carrier plates "
                                           f"{[tuple(round(v, 6) for v in p) for p in plates]} m; valid: "
                                           f"{s}.inner_face_position and the plate thicknesses that contain it")

    def geometry(self, crank_radius, crank_angles):
        """Netgen CSG solid of the carrier (module docstring)."""
        from netgen.csg import CSGeometry, Cylinder, Plane, Pnt, Vec
        big = 10.0 * (self.output_face + self.end_plate_thickness + self.outer_radius)

        def zcyl(x, y, r):
            return Cylinder(Pnt(x, y, -big), Pnt(x, y, big), r)

        def slab(z0, z1):
            return Plane(Pnt(0, 0, z0), Vec(0, 0, -1)) * Plane(Pnt(0, 0, z1), Vec(0, 0, 1))

        disc = zcyl(0, 0, self.outer_radius).bc("outer")
        holes = [zcyl(0, 0, self.bore_radius).bc("bore")] + [
            zcyl(crank_radius * math.cos(b), crank_radius * math.sin(b), self.seat_radius).bc(f"seat{k}")
            for k, b in enumerate(crank_angles)]
        (f0, f1), (e0, e1) = self.plates()
        output = Plane(Pnt(0, 0, f1), Vec(0, 0, 1)).bc("output")
        solid = disc * Plane(Pnt(0, 0, f0), Vec(0, 0, -1)) * output
        solid = solid + disc * slab(e0, e1)
        for a in pillar_angles(crank_angles):
            c, s_ = math.cos(a), math.sin(a)
            if self.pillar_shape == "circular":
                p = zcyl(self.pillar_circle_radius * c, self.pillar_circle_radius * s_, self.pillar_radius)
            else:
                half = 0.5 * self.pillar_angle
                p = (zcyl(0, 0, self.pillar_circle_radius + self.pillar_radius)
                     - zcyl(0, 0, self.pillar_circle_radius - self.pillar_radius))
                # the sector between the two half-planes at a -+ half (outward normals)
                p = p * Plane(Pnt(0, 0, 0), Vec(math.sin(a - half), -math.cos(a - half), 0)) \
                    * Plane(Pnt(0, 0, 0), Vec(-math.sin(a + half), math.cos(a + half), 0))
            solid = solid + p * slab(e1, f0)
        for hole in holes:
            solid = solid - hole
        geo = CSGeometry()
        geo.Add(solid)
        return geo


def pillar_angles(crank_angles):
    """Angles [rad] of the pillars: midway between neighbouring cranks."""
    b = np.sort(np.mod(np.asarray(crank_angles, float), 2 * math.pi))
    nxt = np.roll(b, -1) + np.where(np.arange(len(b)) == len(b) - 1, 2 * math.pi, 0.0)
    return tuple(float(v) for v in 0.5 * (b + nxt))


def _pillar_seat_gap(spec, crank_radius, crank_angles):
    """Smallest clearance [m] between a pillar and a crank seat (in the plane; the pillar's outline is
    sampled)."""
    seats = np.array([[crank_radius * math.cos(b), crank_radius * math.sin(b)] for b in crank_angles])
    gap = math.inf
    for a in pillar_angles(crank_angles):
        if spec.pillar_shape == "circular":
            c = spec.pillar_circle_radius * np.array([math.cos(a), math.sin(a)])
            gap = min(gap, float(np.min(np.linalg.norm(seats - c, axis=1))) - spec.seat_radius - spec.pillar_radius)
        else:
            t = np.linspace(a - spec.pillar_angle / 2, a + spec.pillar_angle / 2, 181)
            r = spec.pillar_circle_radius + spec.pillar_radius * np.linspace(-1.0, 1.0, 21)
            pts = np.stack([np.outer(r, np.cos(t)).ravel(), np.outer(r, np.sin(t)).ravel()], axis=1)
            d = np.linalg.norm(pts[:, None, :] - seats[None, :, :], axis=2)
            gap = min(gap, float(d.min()) - spec.seat_radius)
    return gap


@dataclass(frozen=True)
class CarrierFE:
    """Parent of the carrier (output face clamped) on its free coordinates: ``stiffness`` K [N/m] and ``mass``
    M [kg] (SciPy CSR), ``port_matrix`` P (n_rows, n) of the distributed ports (module docstring),
    ``port_names`` and ``port_rows`` (rows of P per port), ``seat_areas`` [m^2] per seat, ``counts`` (mesh and
    coordinate counts) and the NGSolve objects the surface forms are built on (``forms``, for
    :meth:`rigid_fit` and :meth:`rigid_modes`)."""
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    port_matrix: sp.csr_matrix
    port_names: tuple
    port_rows: tuple
    seat_areas: dict
    counts: dict
    forms: object

    @property
    def n_dofs(self):
        return self.stiffness.shape[0]

    @property
    def damping(self):
        """No structural damping is stated for the carrier (quasi-static seats): zero [N s/m]."""
        return sp.csr_matrix(self.stiffness.shape)

    def solve(self, F):
        """K^-1 F [m] on the free coordinates for loads F (n,) or (n, k) [N]: NGSolve's sparse Cholesky
        factorization of the clamped carrier (made once; SciPy's SuperLU did not finish a quadratic carrier of
        16,000 coordinates within minutes, NGSolve's factorizes 19,000 in 0.6 s)."""
        return self.forms.solve(F)

    def compliance(self, port_matrix=None):
        """Static compliance P K^-1 P^T [m/N] of the ports (default: the distributed seat ports)."""
        P = sp.csr_matrix(self.port_matrix if port_matrix is None else port_matrix)
        C = P @ self.solve(P.T.toarray())
        return 0.5 * (C + C.T)

    def rigid_fit(self, seats, centre):
        """Port matrix A (6, n) of the area-weighted least-squares rigid motion (translations x, y, z [m], small
        rotations about x, y, z [rad] through ``centre`` [m]) of the union of ``seats`` (``"main_flange"``,
        ``"main_end_plate"``, ``"crank{k}_flange"``, ...): A = G^-1 B with G_jl = int R_j . R_l dS and
        B_j(u) = int R_j . u dS over the seats (R_j the rigid fields), an RBE3-type port whose load
        distribution A^T F spreads a force and moment over the seats. A K^-1 A^T is its compliance
        [m/N, rad/(N m)]."""
        return self.forms.rigid_fit(seats, centre)

    def rigid_modes(self, centre=(0.0, 0.0, 0.0)):
        """The six rigid displacement fields (n, 6) on the free coordinates (translations x, y, z, small
        rotations about x, y, z through ``centre``), interpolated (exact for the linear fields)."""
        return self.forms.rigid_modes(centre)


class _SurfaceForms:
    """Surface integrals over the carrier's named boundaries on one NGSolve space (free coordinates only), and
    the space's stiffness factorization."""

    def __init__(self, mesh, fes, free, plates, stiffness_form):
        self.mesh, self.fes, self.free = mesh, fes, free
        self.plates = plates
        self.stiffness_form = stiffness_form
        self._inverse = None

    def solve(self, F):
        import ngsolve as ngs
        if self._inverse is None:
            with ngs.TaskManager():
                self._inverse = self.stiffness_form.mat.Inverse(self.fes.FreeDofs(), inverse="sparsecholesky")
        F = np.asarray(F, float)
        cols = F.reshape(len(F), -1)
        out = np.zeros_like(cols)
        b = self.stiffness_form.mat.CreateColVector()
        x = self.stiffness_form.mat.CreateColVector()
        full = np.zeros(len(self.free))
        for j in range(cols.shape[1]):
            full[:] = 0.0
            full[self.free] = cols[:, j]
            b.FV().NumPy()[:] = full
            x.data = self._inverse * b
            out[:, j] = x.FV().NumPy()[self.free]
        return out.reshape(F.shape)

    def seat(self, name):
        """(boundary name, indicator CoefficientFunction) of a seat ``crank{k}_flange``, ``main_end_plate``, ..."""
        import ngsolve as ngs
        base, side = name.rsplit("_", 1) if not name.endswith("end_plate") else (name[:-len("_end_plate")], "end_plate")
        region = "outer" if base == "main" else f"seat{base[len('crank'):]}"
        (f0, _), (_, e1) = self.plates
        mid = 0.5 * (f0 + e1)           # the plates are disjoint in z: the mid-plane between them splits a bore
        ind = ngs.IfPos(ngs.z - mid, 1.0, 0.0) if side == "flange" else ngs.IfPos(mid - ngs.z, 1.0, 0.0)
        return region, ind

    def area(self, name):
        import ngsolve as ngs
        region, ind = self.seat(name)
        return float(ngs.Integrate(ind, self.mesh, ngs.BND, definedon=self.mesh.Boundaries(region)))

    def form(self, cf, seats):
        """Row int_{seats} cf . v dS (n_free,) for a vector CoefficientFunction cf."""
        import ngsolve as ngs
        v = self.fes.TestFunction()
        lf = ngs.LinearForm(self.fes)
        for name in seats:
            region, ind = self.seat(name)
            lf += ind * ngs.InnerProduct(cf, v) * ngs.ds(region)
        lf.Assemble()
        return lf.vec.FV().NumPy()[self.free].copy()

    def _rigid_fields(self, centre):
        import ngsolve as ngs
        cx, cy, cz = (float(c) for c in centre)
        rx, ry, rz = ngs.x - cx, ngs.y - cy, ngs.z - cz
        CF = ngs.CoefficientFunction
        # u = theta x r: about x (0, -r_z, r_y), about y (r_z, 0, -r_x), about z (-r_y, r_x, 0)
        return [CF((1, 0, 0)), CF((0, 1, 0)), CF((0, 0, 1)), CF((0, -rz, ry)), CF((rz, 0, -rx)), CF((-ry, rx, 0))]

    def rigid_fit(self, seats, centre):
        import ngsolve as ngs
        R = self._rigid_fields(centre)
        G = np.zeros((6, 6))
        for name in seats:
            region, ind = self.seat(name)
            for a in range(6):
                for b in range(a, 6):
                    G[a, b] += float(ngs.Integrate(ind * ngs.InnerProduct(R[a], R[b]), self.mesh, ngs.BND,
                                                   definedon=self.mesh.Boundaries(region)))
        G = np.triu(G) + np.triu(G, 1).T
        B = np.array([self.form(Rj, seats) for Rj in R])
        return sp.csr_matrix(np.linalg.solve(G, B))

    def rigid_modes(self, centre):
        import ngsolve as ngs
        gf = ngs.GridFunction(self.fes)
        out = []
        for Rj in self._rigid_fields(centre):
            gf.Set(Rj)
            out.append(gf.vec.FV().NumPy()[self.free].copy())
        return np.array(out).T


def carrier_fe(spec: CarrierStructure, material: ElasticMaterial, crank_radius, crank_angles, *,
               order=None) -> CarrierFE:
    """Mesh the carrier (curved above order 1), clamp its output face and build the distributed ports as
    surface integrals (module docstring). order: the displacement's polynomial order [-] (None: the spec's
    ``element_order``)."""
    import ngsolve as ngs
    order = spec.element_order if order is None else int(order)
    mesh = generate_mesh(spec.geometry(crank_radius, crank_angles), spec.mesh_size)
    if order > 1:
        mesh.Curve(order)
    fes = ngs.VectorH1(mesh, order=order, dirichlet="output")
    mu, lam = material.lame()
    u, v = fes.TnT()
    eu, ev = ngs.Sym(ngs.Grad(u)), ngs.Sym(ngs.Grad(v))
    a = ngs.BilinearForm(fes, symmetric=True)
    a += (2 * mu * ngs.InnerProduct(eu, ev) + lam * ngs.Trace(eu) * ngs.Trace(ev)) * ngs.dx
    m = ngs.BilinearForm(fes, symmetric=False)
    m += material.density * ngs.InnerProduct(u, v) * ngs.dx
    with ngs.TaskManager():
        a.Assemble()
        m.Assemble()
    free = np.array([bool(b) for b in fes.FreeDofs()])
    K = sp.csr_matrix(a.mat.CSR())[free][:, free]     # CSR() gives the full matrix of a symmetric form
    M = sp.csr_matrix(m.mat.CSR())[free][:, free]
    # NGSolve's assembly is symmetric to round-off; the average removes that asymmetry exactly
    K, M = ((A + A.T) * 0.5 for A in (K, M))
    forms = _SurfaceForms(mesh, fes, free, spec.plates(), a)
    names = tuple(f"crank{k}" for k in range(len(crank_angles))) + ("main_bearing",)
    areas, rows = {}, []
    ex, ey = ngs.CoefficientFunction((1, 0, 0)), ngs.CoefficientFunction((0, 1, 0))
    for name in names:
        base = "main" if name == "main_bearing" else name
        seats = (f"{base}_flange", f"{base}_end_plate")
        for seat in seats:
            areas[seat] = forms.area(seat)
            if not areas[seat] > 0.0:
                raise RvtoolInputError(f"carrier.structure: the seat {seat!r} has no surface in the mesh "
                                       f"(mesh_size = {spec.mesh_size} m); valid: a finer mesh_size")
        # each of the two seats carries half of the port's load: u_g = sum_s (1/2) int_s u dS / A_s
        for e in (ex, ey):
            rows.append(sum(0.5 * forms.form(e, (seat,)) / areas[seat] for seat in seats))
    P = sp.csr_matrix(np.array(rows))
    P.eliminate_zeros()
    counts = {"vertices": int(mesh.nv), "elements": int(mesh.ne), "dofs": int(free.sum()),
              "element_order": int(order)}
    return CarrierFE(stiffness=K.tocsr(), mass=M.tocsr(), port_matrix=P, port_names=names,
                     port_rows=tuple(np.array([2 * g, 2 * g + 1]) for g in range(len(names))), seat_areas=areas,
                     counts=counts, forms=forms)


def reduce_carrier(parent: CarrierFE, n_modes: int) -> PortReducedModel:
    """Ritz reduction on the static port modes and ``n_modes`` clamped modes (module docstring)."""
    fe = parent
    static = parent.solve(parent.port_matrix.T.toarray())
    basis = [static]
    if n_modes > 0:
        if n_modes >= fe.n_dofs - 1:
            raise RvtoolInputError(f"carrier.structure.n_modes = {n_modes} is outside the valid range "
                                   f"[0, {fe.n_dofs - 2}]")
        op = spla.LinearOperator(fe.stiffness.shape, matvec=parent.solve, dtype=float)
        _, phi = spla.eigsh(fe.stiffness, k=n_modes, M=fe.mass, sigma=0.0, OPinv=op, which="LM")
        basis.append(phi)
    X = np.hstack(basis)
    Kp, Mp = X.T @ (fe.stiffness @ X), X.T @ (fe.mass @ X)
    w2, Q = sla.eigh(0.5 * (Kp + Kp.T), 0.5 * (Mp + Mp.T))
    phi = X @ Q
    H = np.asarray(parent.port_matrix @ phi)
    Ceta = phi.T @ (fe.damping @ phi)
    return PortReducedModel(basis=phi, omega2=w2, damping=0.5 * (Ceta + Ceta.T), maps=H, port_rows=parent.port_rows,
                            local_correction=None, n_modes=int(n_modes), n_residual=int(static.shape[1]))
