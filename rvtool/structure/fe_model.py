"""Finite-element parent model of a structural component (NGSolve), with nodal ports and supports.

A generic constructor meshes any Netgen geometry (CSG or OCC) or takes an
existing NGSolve mesh, assembles linear-elastic stiffness and consistent mass
with first-order displacement tetrahedra in NGSolve and exports them as SciPy
CSR matrices. Ports are the Cartesian (or declared-direction) components of the
mesh vertices nearest to declared points; one port row is one row of the
selection matrix P of Eq. (body_compliance). Supports are translational springs
added to K at the nearest vertices, or clamps that remove a vertex's
coordinates. Rayleigh damping C = alpha M + beta K_e uses the elastic stiffness
K_e only: the mounting springs carry no damping (Table tab:ports_inputs, "no
added mount damping"), which makes the projected damping non-proportional.

Coordinates are ordered node-interleaved (x0, y0, z0, x1, ...), the layout of
``exudyn.FEM.FEMinterface``; clamped coordinates are removed, and
``dof_vertex`` / ``dof_component`` name every remaining coordinate.

:func:`annular_housing` is the mounted annulus of Table (tab:supp_ports_inputs).
"""
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import RvtoolInputError
from ..validation import check_positive, check_range, check_shape

MAX_PORTS = 256
"""Largest ``n_ports`` and ``n_mounts`` of an annular housing (a cost limit, :class:`AnnularHousingSpec`)."""
MAX_STRUCTURE_MODES = 200
"""Largest count of retained modes of an elastic structure (``housing.n_modes``,
``housing.n_fixed_interface_modes``, ``carrier.structure.n_modes``): a cost limit. Each mode is an
eigenpair of the FE model's sparse shift-invert solve and a coordinate of every Newton step (dense
blocks); 200 is ten times the defaults (12, 20, 6) and above the 2 x 40 port rows of the shipped
designs. A mistyped 1e6 would mesh and factor the structure for minutes before the build's own
check against the FE model's size."""


@dataclass(frozen=True, kw_only=True)
class ElasticMaterial:
    """Isotropic linear-elastic material.

    youngs_modulus: E [Pa]; poisson_ratio: nu [-], in (-1, 0.5); density: rho [kg/m^3].
    """
    youngs_modulus: float
    poisson_ratio: float
    density: float

    def __post_init__(self):
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, -1.0, 0.5, low_open=True, high_open=True)
        check_positive("density", self.density)

    def lame(self):
        """Lame parameters (mu, lambda) [Pa]."""
        E, nu = self.youngs_modulus, self.poisson_ratio
        return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


@dataclass(frozen=True, kw_only=True)
class NodalPort:
    """A contact port at the mesh vertex nearest to ``point``.

    name: label; point: requested location [m] (3,); directions: unit row vectors
    (k, 3) of the sampled displacement components [-]; the default (identity)
    samples the three global translations, a single normal gives a normal port.
    """
    name: str
    point: tuple
    directions: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

    def __post_init__(self):
        check_shape(f"port {self.name!r} point", self.point, (3,))
        d = check_shape(f"port {self.name!r} directions", self.directions, (None, 3)).astype(float)
        n = np.linalg.norm(d, axis=1)
        if d.shape[0] < 1 or np.any(np.abs(n - 1) > 1e-12):
            raise RvtoolInputError(f"port {self.name!r} directions have norms {n.tolist()}; valid: 1 to 3 unit vectors")


@dataclass(frozen=True, kw_only=True)
class NodalSpring:
    """Translational grounding spring at the mesh vertex nearest to ``point``.

    point: requested location [m] (3,); stiffness: (k_x, k_y, k_z) [N/m], each >= 0.
    """
    point: tuple
    stiffness: tuple

    def __post_init__(self):
        check_shape("spring point", self.point, (3,))
        check_shape("spring stiffness", self.stiffness, (3,))
        check_range("spring stiffness", self.stiffness, 0.0)


@dataclass(frozen=True, kw_only=True)
class NodalClamp:
    """All three translations of the mesh vertex nearest to ``point`` [m] held at zero."""
    point: tuple

    def __post_init__(self):
        check_shape("clamp point", self.point, (3,))


@dataclass(frozen=True, kw_only=True)
class RayleighDamping:
    """Rayleigh damping C = alpha M + beta K_e calibrated to ``damping_ratio`` zeta [-] at the two
    ``calibration_frequencies`` (f_a, f_b) [Hz], f_a < f_b. zeta = 0 is the undamped variant."""
    damping_ratio: float
    calibration_frequencies: tuple

    def __post_init__(self):
        check_range("damping_ratio", self.damping_ratio, 0.0, 1.0, high_open=True)
        f = check_shape("calibration_frequencies", self.calibration_frequencies, (2,)).astype(float)
        check_positive("calibration_frequencies", f)
        if not f[0] < f[1]:
            raise RvtoolInputError(f"calibration_frequencies = {[float(x) for x in f]} [Hz] must be increasing "
                                   "(valid: f_a < f_b, both > 0)")

    def coefficients(self):
        """(alpha [1/s], beta [s]) from zeta = alpha/(2 w) + beta w / 2 at both calibration frequencies."""
        wa, wb = 2 * math.pi * np.asarray(self.calibration_frequencies, float)
        z = self.damping_ratio
        return 2 * z * wa * wb / (wa + wb), 2 * z / (wa + wb)


@dataclass(frozen=True)
class PortGroup:
    """Resolved port: ``vertex`` index, requested-point ``distance`` [m] to it, ``rows`` of the
    stacked port vector that belong to it, ``directions`` (k, 3)."""
    name: str
    vertex: int
    distance: float
    rows: np.ndarray
    directions: np.ndarray


@dataclass(frozen=True)
class FEModel:
    """Assembled parent model (arrays are not copied; treat them as read-only).

    vertices (nv, 3) [m]; tetrahedra (ne, 4) and surface_triangles (nt, 3) vertex indices;
    stiffness K [N/m] incl. springs and elastic_stiffness K_e [N/m], mass M [kg], damping C
    [N s/m], all SciPy CSR on the free coordinates; dof_vertex, dof_component (n,);
    ports: PortGroup per port; port_matrix P (n_port_rows, n) CSR; spring_vertices and
    clamped_vertices: vertex indices of the supports; damping_coefficients (alpha, beta).
    """
    vertices: np.ndarray
    tetrahedra: np.ndarray
    surface_triangles: np.ndarray
    stiffness: sp.csr_matrix
    elastic_stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    damping: sp.csr_matrix
    dof_vertex: np.ndarray
    dof_component: np.ndarray
    ports: tuple
    port_matrix: sp.csr_matrix
    spring_vertices: np.ndarray
    clamped_vertices: np.ndarray
    damping_coefficients: tuple
    material: ElasticMaterial
    info: dict = field(default_factory=dict)

    @property
    def n_dofs(self):
        return self.stiffness.shape[0]

    @property
    def port_dofs(self):
        """Free-coordinate indices of all coordinates of the port vertices (CB boundary set)."""
        return np.concatenate([self.vertex_dofs(p.vertex) for p in self.ports]) if self.ports else np.zeros(0, int)

    def vertex_dofs(self, vertex):
        """Free-coordinate indices (x, y, z order) of one vertex."""
        idx = self._dof_index()[int(vertex)]
        if np.any(idx < 0):
            raise RvtoolInputError(f"vertex {vertex} is clamped; its coordinates are not free")
        return idx

    def _dof_index(self):
        table = np.full((len(self.vertices), 3), -1, dtype=int)
        table[self.dof_vertex, self.dof_component] = np.arange(self.n_dofs)
        return table

    def rigid_body_modes(self, centre=(0.0, 0.0, 0.0)):
        """Six rigid-body displacement fields (n, 6): translations x, y, z and small rotations
        about x, y, z through ``centre`` [m], on the free coordinates."""
        r = self.vertices[self.dof_vertex] - np.asarray(centre, float)
        R = np.zeros((self.n_dofs, 6))
        c = self.dof_component
        R[np.arange(self.n_dofs), c] = 1.0
        # u = theta x r: (theta_x e_x) x r = (0, -r_z, r_y), etc.
        rot = np.zeros((self.n_dofs, 3))
        rot[c == 0, 1], rot[c == 0, 2] = r[c == 0, 2], -r[c == 0, 1]
        rot[c == 1, 0], rot[c == 1, 2] = -r[c == 1, 2], r[c == 1, 0]
        rot[c == 2, 0], rot[c == 2, 1] = r[c == 2, 1], -r[c == 2, 0]
        R[:, 3:] = rot
        return R

    def port_selector(self, ports=None):
        """Rows of P for the given port indices (default: all) as CSR."""
        if ports is None:
            return self.port_matrix
        rows = np.concatenate([self.ports[int(g)].rows for g in ports])
        return self.port_matrix[rows]

    def counts(self):
        """Mesh and coordinate counts."""
        return {"vertices": int(len(self.vertices)), "elements": int(len(self.tetrahedra)),
                "dofs": int(self.n_dofs), "port_rows": int(self.port_matrix.shape[0])}


def generate_mesh(geometry, mesh_size):
    """Mesh a Netgen geometry (netgen.csg.CSGeometry or netgen.occ.OCCGeometry) with nominal
    element size ``mesh_size`` [m] and return an ``ngsolve.Mesh``."""
    import ngsolve as ngs
    check_positive("mesh_size", mesh_size)
    return ngs.Mesh(geometry.GenerateMesh(maxh=mesh_size))


def _assemble(mesh, material):
    """K_e and M on the node-interleaved coordinates (SciPy CSR) via NGSolve first-order VectorH1."""
    import ngsolve as ngs
    # NGSolve orders VectorH1 coordinates component-blocked (all x, then y, then z); its interleaved
    # option assembled half the mass in NGSolve 6.2.2608 (rigid translation not in the kernel of K),
    # so the blocked matrices are permuted here.
    fes = ngs.VectorH1(mesh, order=1)
    nv = mesh.nv
    if fes.ndof != 3 * nv:
        raise RvtoolInputError(f"first-order VectorH1 has {fes.ndof} coordinates for {nv} vertices; a mesh of "
                               "straight first-order tetrahedra is required")
    mu, lam = material.lame()
    u, v = fes.TnT()
    eps_u, eps_v = ngs.Sym(ngs.Grad(u)), ngs.Sym(ngs.Grad(v))
    a = ngs.BilinearForm(fes)
    a += (2 * mu * ngs.InnerProduct(eps_u, eps_v) + lam * ngs.Trace(eps_u) * ngs.Trace(eps_v)) * ngs.dx
    m = ngs.BilinearForm(fes)
    m += material.density * u * v * ngs.dx
    with ngs.TaskManager():
        a.Assemble()
        m.Assemble()
    blocked = np.arange(3 * nv).reshape(3, nv).T.ravel()   # interleaved index 3 i + c -> blocked c nv + i
    K = sp.csr_matrix(a.mat.CSR())[blocked][:, blocked]
    M = sp.csr_matrix(m.mat.CSR())[blocked][:, blocked]
    # NGSolve's assembly is symmetric to round-off; the average removes that asymmetry exactly
    K = ((K + K.T) * 0.5).tocsr()
    M = ((M + M.T) * 0.5).tocsr()
    return K, M


def _nearest(vertices, points):
    """Indices of the mesh vertices nearest to ``points`` and their distances [m]."""
    from scipy.spatial import cKDTree
    dist, idx = cKDTree(vertices).query(np.atleast_2d(np.asarray(points, float)))
    return np.asarray(idx, int), np.asarray(dist, float)


def fe_model_from_mesh(mesh, *, material: ElasticMaterial, ports=(), supports=(),
                       damping: RayleighDamping | None = None, info=None) -> FEModel:
    """Parent model on an NGSolve mesh of first-order tetrahedra.

    ports: sequence of :class:`NodalPort` (nearest vertices; two ports may not share one);
    supports: :class:`NodalSpring` and :class:`NodalClamp` entries (nearest vertices; springs at the
    same vertex add); damping: :class:`RayleighDamping` (None: undamped).
    """
    ngm = mesh.ngmesh
    vertices = np.asarray(ngm.Coordinates(), dtype=float).copy()
    tets = np.asarray(ngm.Elements3D().NumPy()["nodes"], dtype=int) - 1   # Netgen point numbers are 1-based
    tris = np.asarray(ngm.Elements2D().NumPy()["nodes"], dtype=int) - 1
    if tets.shape[1] != 4 or tets.min() < 0 or tets.max() >= len(vertices):
        raise RvtoolInputError(f"mesh elements have {tets.shape[1]} vertices; first-order tetrahedra (4) are required")
    K_e, M = _assemble(mesh, material)

    n_all = 3 * len(vertices)
    k_spring = np.zeros(n_all)
    spring_vertices, clamped = [], []
    for s in supports:
        if isinstance(s, NodalSpring):
            (vtx,), _ = _nearest(vertices, [s.point])
            k_spring[3 * vtx:3 * vtx + 3] += np.asarray(s.stiffness, float)
            spring_vertices.append(int(vtx))
        elif isinstance(s, NodalClamp):
            (vtx,), _ = _nearest(vertices, [s.point])
            clamped.append(int(vtx))
        else:
            raise RvtoolInputError(f"supports contains {type(s).__name__}; valid: NodalSpring, NodalClamp")
    K = (K_e + sp.diags(k_spring)).tocsr()

    keep = np.ones(n_all, dtype=bool)
    for vtx in clamped:
        keep[3 * vtx:3 * vtx + 3] = False
    free = np.flatnonzero(keep)
    K, K_e, M = (A[free][:, free].tocsr() for A in (K, K_e, M))
    dof_vertex, dof_component = free // 3, free % 3

    alpha, beta = damping.coefficients() if damping is not None else (0.0, 0.0)
    C = (alpha * M + beta * K_e).tocsr()

    table = np.full((len(vertices), 3), -1, dtype=int)
    table[dof_vertex, dof_component] = np.arange(len(free))
    groups, rows_i, cols_i, vals = [], [], [], []
    row = 0
    if ports:
        pv, pdist = _nearest(vertices, [p.point for p in ports])
        seen = {}
        for p, vtx, dist in zip(ports, pv, pdist):
            if int(vtx) in seen:
                raise RvtoolInputError(f"ports {seen[int(vtx)]!r} and {p.name!r} both map to mesh vertex {vtx}; "
                                       "refine the mesh (mesh_size) or space the ports further apart")
            if int(vtx) in clamped:
                raise RvtoolInputError(f"port {p.name!r} maps to clamped vertex {vtx}; a port must lie on free coordinates")
            seen[int(vtx)] = p.name
            d = np.asarray(p.directions, float)
            rows = np.arange(row, row + len(d))
            for k, dk in enumerate(d):
                for c in range(3):
                    if dk[c] != 0.0:
                        rows_i.append(row + k)
                        cols_i.append(table[vtx, c])
                        vals.append(dk[c])
            groups.append(PortGroup(name=p.name, vertex=int(vtx), distance=float(dist), rows=rows, directions=d))
            row += len(d)
    P = sp.csr_matrix((vals, (rows_i, cols_i)), shape=(row, len(free)))
    return FEModel(vertices=vertices, tetrahedra=tets, surface_triangles=tris, stiffness=K, elastic_stiffness=K_e,
                   mass=M, damping=C, dof_vertex=dof_vertex, dof_component=dof_component, ports=tuple(groups),
                   port_matrix=P, spring_vertices=np.asarray(spring_vertices, int),
                   clamped_vertices=np.asarray(clamped, int), damping_coefficients=(alpha, beta),
                   material=material, info=dict(info or {}))


def fe_model_from_geometry(geometry, *, mesh_size, material, ports=(), supports=(), damping=None, info=None):
    """Mesh a Netgen geometry with nominal size ``mesh_size`` [m], then :func:`fe_model_from_mesh`."""
    mesh = generate_mesh(geometry, mesh_size)
    return fe_model_from_mesh(mesh, material=material, ports=ports, supports=supports, damping=damping,
                              info={"mesh_size": mesh_size, **(info or {})})


@dataclass(frozen=True, kw_only=True)
class AnnularHousingSpec:
    """Mounted annular housing of Table (tab:supp_ports_inputs).

    inner_radius: bore radius [m]. outer_radius: outer radius [m]. height: axial height [m].
    material: the housing's material. mesh_size: nominal tetrahedron size [m].
    n_ports: number of pin ports [-], at equal angles theta_j = 2 pi j / n_ports on the inner
    surface, three translations each. port_height: axial station of the ports [m] (None:
    mid-height). n_mounts: number of mount springs [-], at equal angles on the lower face (z = 0).
    mount_radius: radius of the mount circle [m]. mount_stiffness: stiffness of each mount per
    Cartesian direction [N/m]. damping: the Rayleigh calibration.
    """
    inner_radius: float = 0.105
    outer_radius: float = 0.125
    height: float = 0.0676
    material: ElasticMaterial = ElasticMaterial(youngs_modulus=210e9, poisson_ratio=0.3, density=7850.0)
    mesh_size: float = 0.006667
    n_ports: int = 52
    port_height: float | None = None
    n_mounts: int = 18
    mount_radius: float = 0.1165
    mount_stiffness: float = 5.556e6
    damping: RayleighDamping = RayleighDamping(damping_ratio=0.02, calibration_frequencies=(500.0, 5000.0))

    def __post_init__(self):
        check_positive("inner_radius", self.inner_radius)
        check_range("outer_radius", self.outer_radius, self.inner_radius, math.inf, low_open=True)
        check_positive("height", self.height)
        check_range("mesh_size", self.mesh_size, 0.0, self.height, low_open=True)
        # upper bound: a cost limit. One port per ring pin, two coordinates each, and the port reduction's static
        # compliance is a dense (2 n_ports)^2 block of every Newton step; 256 is over six times the 40 pins of
        # the shipped designs (a mistyped 1e6 meshed for minutes instead of failing)
        if isinstance(self.n_ports, bool) or not isinstance(self.n_ports, int) or not 1 <= self.n_ports <= MAX_PORTS:
            raise RvtoolInputError(f"n_ports = {self.n_ports!r} is outside the valid range [1, {MAX_PORTS}] (integer)")
        # upper bound: a cost limit as n_ports (each mount a spring on the FE model's lower face)
        if isinstance(self.n_mounts, bool) or not isinstance(self.n_mounts, int) or not 0 <= self.n_mounts <= MAX_PORTS:
            raise RvtoolInputError(f"n_mounts = {self.n_mounts!r} is outside the valid range [0, {MAX_PORTS}] (integer)")
        if self.port_height is not None:
            check_range("port_height", self.port_height, 0.0, self.height)
        check_range("mount_radius", self.mount_radius, self.inner_radius, self.outer_radius)
        check_positive("mount_stiffness", self.mount_stiffness)

    def port_angles(self):
        """theta_j = 2 pi j / n_ports [rad]."""
        return 2 * math.pi * np.arange(self.n_ports) / self.n_ports

    def geometry(self):
        """Netgen CSG solid: the annulus between z = 0 and z = height."""
        from netgen.csg import CSGeometry, Cylinder, Plane, Pnt, Vec
        big = 10 * self.height   # the cylinder axis only has to span the slab
        solid = (Cylinder(Pnt(0, 0, -big), Pnt(0, 0, big), self.outer_radius)
                 * Plane(Pnt(0, 0, 0), Vec(0, 0, -1)) * Plane(Pnt(0, 0, self.height), Vec(0, 0, 1))
                 - Cylinder(Pnt(0, 0, -big), Pnt(0, 0, big), self.inner_radius))
        geo = CSGeometry()
        geo.Add(solid)
        return geo

    def ports(self):
        z = 0.5 * self.height if self.port_height is None else self.port_height
        return tuple(NodalPort(name=f"pin{j}", point=(self.inner_radius * math.cos(t), self.inner_radius * math.sin(t), z))
                     for j, t in enumerate(self.port_angles()))

    def supports(self):
        phi = 2 * math.pi * np.arange(self.n_mounts) / max(self.n_mounts, 1)
        k = (self.mount_stiffness,) * 3
        return tuple(NodalSpring(point=(self.mount_radius * math.cos(p), self.mount_radius * math.sin(p), 0.0), stiffness=k)
                     for p in phi)


def annular_housing(spec: AnnularHousingSpec = AnnularHousingSpec()) -> FEModel:
    """Parent FE model of the mounted annular housing (one instance of :func:`fe_model_from_geometry`)."""
    return fe_model_from_geometry(spec.geometry(), mesh_size=spec.mesh_size, material=spec.material,
                                  ports=spec.ports(), supports=spec.supports(), damping=spec.damping,
                                  info={"component": "annular housing"})
