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
from .craig_bampton import factorize
from .fe_model import ElasticMaterial, NodalClamp, fe_model_from_mesh, generate_mesh
from .port_reduction import PortReducedModel
from .static import SupportedCompliance

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
    mesh_size: nominal tetrahedron size [m]. n_modes: clamped-carrier modes kept beside the static port
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
        if isinstance(self.n_modes, bool) or not isinstance(self.n_modes, int) or self.n_modes < 0:
            raise RvtoolInputError(f"carrier.structure.n_modes = {self.n_modes!r} is outside the valid range "
                                   "[0, inf) (integer)")

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
                                   f"(0, {min(crank_radius - self.bore_radius, self.outer_radius - crank_radius):.6g}) m")
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

        disc = zcyl(0, 0, self.outer_radius)
        holes = [zcyl(0, 0, self.bore_radius)] + [zcyl(crank_radius * math.cos(b), crank_radius * math.sin(b),
                                                       self.seat_radius) for b in crank_angles]
        (f0, f1), (e0, e1) = self.plates()
        solid = disc * slab(f0, f1)
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
    """Parent of the carrier: ``fe`` (:class:`~rvtool.structure.fe_model.FEModel`, output face clamped),
    ``port_matrix`` P (n_rows, n_dofs) of the distributed ports (module docstring), ``port_names`` and
    ``port_rows`` (rows of P per port), ``seat_vertices`` (vertex indices per seat)."""
    fe: object
    port_matrix: sp.csr_matrix
    port_names: tuple
    port_rows: tuple
    seat_vertices: dict

    def compliance(self):
        """Parent static port compliance P K^-1 P^T [m/N] (one sparse factorization)."""
        return SupportedCompliance(self.fe.stiffness, self.port_matrix).compliance()

    def rigid_fit(self, seats, centre):
        """Port matrix A (6, n_dofs) of the area-weighted least-squares rigid motion (translations x, y, z [m],
        small rotations about x, y, z [rad] through ``centre`` [m]) of the union of ``seats`` (names of
        ``seat_vertices``): A = (R^T W R)^-1 R^T W on their coordinates, an RBE3-type port whose load
        distribution A^T F spreads a force and moment over the seats. A K^-1 A^T is its compliance
        [m/N, rad/(N m)]."""
        fe = self.fe
        V = fe.vertices
        tris = fe.surface_triangles
        idx = np.unique(np.concatenate([self.seat_vertices[n] for n in seats]))
        w = _surface_weights(V, tris, idx)[idx]
        table = np.full((len(V), 3), -1, int)
        table[fe.dof_vertex, fe.dof_component] = np.arange(fe.n_dofs)
        r = V[idx] - np.asarray(centre, float)
        n = len(idx)
        R = np.zeros((3 * n, 6))
        for c in range(3):
            R[c::3, c] = 1.0
        # u = theta x r
        R[1::3, 3], R[2::3, 3] = -r[:, 2], r[:, 1]
        R[0::3, 4], R[2::3, 4] = r[:, 2], -r[:, 0]
        R[0::3, 5], R[1::3, 5] = -r[:, 1], r[:, 0]
        Wd = np.repeat(w, 3)
        A_loc = np.linalg.solve(R.T @ (Wd[:, None] * R), (R * Wd[:, None]).T)     # (6, 3 n)
        cols = table[idx].reshape(-1)
        free = cols >= 0
        return sp.csr_matrix((A_loc[:, free].ravel(), (np.repeat(np.arange(6), int(free.sum())),
                                                       np.tile(cols[free], 6))), shape=(6, fe.n_dofs))


def _surface_weights(vertices, triangles, selected):
    """Area weight [m^2] of every selected vertex: a third of the area of each surface triangle whose three
    vertices are selected."""
    sel = np.zeros(len(vertices), bool)
    sel[selected] = True
    tri = triangles[np.all(sel[triangles], axis=1)]
    a = 0.5 * np.linalg.norm(np.cross(vertices[tri[:, 1]] - vertices[tri[:, 0]],
                                      vertices[tri[:, 2]] - vertices[tri[:, 0]]), axis=1)
    w = np.zeros(len(vertices))
    np.add.at(w, tri.ravel(), np.repeat(a / 3.0, 3))
    return w


def carrier_fe(spec: CarrierStructure, material: ElasticMaterial, crank_radius, crank_angles) -> CarrierFE:
    """Mesh the carrier, clamp its output face and build the distributed ports (module docstring)."""
    mesh = generate_mesh(spec.geometry(crank_radius, crank_angles), spec.mesh_size)
    ngm = mesh.ngmesh
    V = np.asarray(ngm.Coordinates(), float)
    tris = np.asarray(ngm.Elements2D().NumPy()["nodes"], int) - 1
    on_surface = np.zeros(len(V), bool)
    on_surface[np.unique(tris)] = True
    tol = 1e-6 + 1e-3 * spec.mesh_size       # boundary vertices are projected onto the CSG surfaces
    face = np.flatnonzero(on_surface & (np.abs(V[:, 2] - spec.output_face) < tol))
    fe = fe_model_from_mesh(mesh, material=material, supports=tuple(NodalClamp(point=tuple(V[i])) for i in face),
                            info={"component": "RV carrier", "mesh_size": spec.mesh_size})
    plates = spec.plates()
    r_xy = np.hypot(V[:, 0], V[:, 1])
    seats = {}
    for k, b in enumerate(crank_angles):
        c = crank_radius * np.array([math.cos(b), math.sin(b)])
        on_bore = on_surface & (np.abs(np.hypot(V[:, 0] - c[0], V[:, 1] - c[1]) - spec.seat_radius) < tol)
        for side, (z0, z1) in zip(("flange", "end_plate"), plates):
            seats[f"crank{k}_{side}"] = np.flatnonzero(on_bore & (V[:, 2] >= z0 - tol) & (V[:, 2] <= z1 + tol))
    outer = on_surface & (np.abs(r_xy - spec.outer_radius) < tol)
    for side, (z0, z1) in zip(("flange", "end_plate"), plates):
        seats[f"main_{side}"] = np.flatnonzero(outer & (V[:, 2] >= z0 - tol) & (V[:, 2] <= z1 + tol))
    table = np.full((len(V), 3), -1, int)
    table[fe.dof_vertex, fe.dof_component] = np.arange(fe.n_dofs)
    rows_i, cols_i, vals = [], [], []
    names = tuple(f"crank{k}" for k in range(len(crank_angles))) + ("main_bearing",)
    for g, name in enumerate(names):
        parts = [seats[f"{name if name != 'main_bearing' else 'main'}_{s}"] for s in ("flange", "end_plate")]
        for part in parts:
            w = _surface_weights(V, tris, part)[part]
            if len(part) < 3 or w.sum() <= 0.0:
                raise RvtoolInputError(f"carrier.structure.mesh_size = {spec.mesh_size} m leaves the seat of port "
                                       f"{name!r} with {len(part)} surface vertices; valid: a finer mesh_size")
            w = 0.5 * w / w.sum()            # each of the two seats carries half of the port's load
            free = table[part] >= 0           # a seat vertex on the clamped face has no free coordinate
            for c in range(2):
                rows_i.extend([2 * g + c] * int(free[:, c].sum()))
                cols_i.extend(table[part, c][free[:, c]].tolist())
                vals.extend(w[free[:, c]].tolist())
    P = sp.csr_matrix((vals, (rows_i, cols_i)), shape=(2 * len(names), fe.n_dofs))
    return CarrierFE(fe=fe, port_matrix=P, port_names=names,
                     port_rows=tuple(np.array([2 * g, 2 * g + 1]) for g in range(len(names))), seat_vertices=seats)


def reduce_carrier(parent: CarrierFE, n_modes: int) -> PortReducedModel:
    """Ritz reduction on the static port modes and ``n_modes`` clamped modes (module docstring)."""
    fe = parent.fe
    lu = factorize(fe.stiffness, "K of the carrier (output face clamped)")
    static = lu.solve(parent.port_matrix.T.toarray())
    basis = [static]
    if n_modes > 0:
        if n_modes >= fe.n_dofs - 1:
            raise RvtoolInputError(f"carrier.structure.n_modes = {n_modes} is outside the valid range "
                                   f"[0, {fe.n_dofs - 2}]")
        op = spla.LinearOperator(fe.stiffness.shape, matvec=lu.solve, dtype=float)
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
