"""Elastic cycloid wheel body: parametric mesh, contact ports and its static port compliance (issue 30).

Geometry (wheel coordinates, z along the axis, 0 <= z <= thickness): the wheel's profile as a
closed polyline through ``samples_per_tooth`` points per tooth of the cycloid profile (the same
:class:`~rvtool.geometry.cycloid.CycloidProfile` the contact law uses), less the crank bores and
the optional pillar (output-pin) and lightening holes, all circles. The plane section is meshed
by Netgen (2D, ``mesh_size``) and extruded into ``layers`` prism layers split into first-order
tetrahedra (each prism into three, the diagonal of every quadrilateral face from its lower global
vertex index, so neighbouring prisms agree), assembled by :func:`fe_model_from_mesh` (NGSolve,
node-interleaved coordinates: the layout of ``exudyn.FEM.FEMinterface`` and of
:func:`~rvtool.structure.floating.floating_basis`). The body is free (no supports).

Ports (planar, rows x, y), every one spread over a patch and work-conjugate (a port force F
applies F w_v at the patch's vertices, the port displacement is sum_v w_v u_v, sum_v w_v = 1):

* ``profile``: one port per profile sample i (``samples_per_tooth`` per tooth), spread along the
  flank over the hat function between the neighbouring samples (weight = hat value x the vertex's
  tributary arc length) and uniformly over the thickness (trapezoid weights over the layers). A
  contact between two samples is carried by the two with its linear interpolation weights
  (:func:`profile_interpolation`), so a contact that moves along the flank moves its load
  continuously;
* ``bore{k}``: crank bore k, the tributary-weighted mean of the bore surface (the needle set's outer
  race carried as the mean motion of the bore);
* ``hole{k}``: pillar / output-pin hole k, likewise;
* ``bore{k}_patches`` (only with ``bore_ports = N > 0``): N radial ports around crank bore k, patch i
  centred at the polar angle 2 pi i / N about the bore centre (from +x of the wheel frame) and
  spread over the hat function in the polar angle between its neighbours (weight = hat value x the
  vertex's tributary arc length x the thickness weight). A patch force p (compression positive)
  pushes every patch vertex along its own outward radius, p w_v n_v; the port displacement is the
  weighted mean outward radial displacement sum_v w_v n_v . u_v (work-conjugate). A journal (or
  the race of its needle row) presses on the loaded arc only: each patch closes against it through
  a compression-only contact (:mod:`rvtool.contact.bore_patches`), so the bore ovalises and the
  unloaded arc carries nothing. The mean rows ``bore{k}`` stay (the patches add rows after all
  other rows).

No double counting of the local contact compliance: the pin contact law already holds the
approach of the wheel's surface relative to its material at the datum depth of a line contact.
The profile ports therefore *measure* the normal displacement at the point ``port_depth`` below
the sample along the inward normal (the tangential one on the surface: the law holds no tangential
approach) (barycentric in the plane mesh, mean over the thickness) while the
load stays spread on the surface, the separation of local (analytic) and global (FE) deformation
of Andersson & Vedmar (J. Mech. Design 125 (2003) 524): the port compliance is
C = sym(P_m K^+ P_l^T), with P_l the load rows, P_m the measurement rows (= P_l on the bores and
holes) and K^+ the inertia-relief compliance of the free wheel
(:class:`~rvtool.structure.static.InertiaReliefCompliance`, six rigid modes; for self-equilibrated
port loads it is the deformation relative to the wheel's mass-weighted rigid frame).
``port_depth = 0`` measures on the surface (the FE's near field counted a second time).
"""
import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import RvtoolInputError
from ..units import angle_field
from ..validation import check_choice, check_nonnegative, check_positive
from .fe_model import ElasticMaterial, FEModel, fe_model_from_mesh


@dataclass(frozen=True, kw_only=True)
class HoleSet:
    """Equal circular holes on a circle.

    count: number of holes [-] (0: none). radius: hole radius [m]. circle_radius: radius of the
    circle of hole centres [m]. angle: polar angle of the first hole from +x [rad] (file: ``angle_deg``).
    """
    count: int = 0
    radius: float = 0.0
    circle_radius: float = 0.0
    angle: float = angle_field(0.0)

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or not 0 <= self.count <= 64:
            raise RvtoolInputError(f"count = {self.count!r} is outside the valid range [0, 64] (integer)")
        if self.count:
            check_positive("radius", self.radius)
            check_nonnegative("circle_radius", self.circle_radius)

    def centres(self):
        a = self.angle + 2 * math.pi * np.arange(self.count) / max(self.count, 1)
        return np.stack([self.circle_radius * np.cos(a), self.circle_radius * np.sin(a)], axis=-1)


ELASTICITIES = ("solid", "plane_stress")
"""The wheel body's elasticity (``wheels.structure.elasticity``): 3D tetrahedra or plane-stress triangles."""


@dataclass(frozen=True, kw_only=True)
class WheelBodySpec:
    """The wheel body's mesh and ports (design file: ``[wheels.structure]``).

    mesh_size: nominal element size of the plane mesh [m]. layers: prism layers through the
    thickness [-]. samples_per_tooth: profile samples (polyline vertices and profile ports) per
    tooth [-]. port_depth: datum depth [m] below the flank at which the profile ports measure
    (module docstring; None: the pin radius, ``assumed``: the datum of a line contact's approach
    is of the order of the contact radii, Johnson, Contact Mechanics (1985) Sec. 5.6; range
    r_p/2 to 2 r_p, the case reports the share at both ends). pillar_holes, lightening_holes:
    :class:`HoleSet` tables (``[wheels.structure.pillar_holes]``; count 0 = none). material: the
    wheel's material (None: the design's ``[material]``). bore_ports: radial patch ports per
    crank bore [-] (0, the default: the bore's mean motion follows its journal, a bilateral tie; 4
    to 64: N compression-only patches around each bore, which the journal's needle row loads on its
    loaded arc only, so the bore ovalises; at most the vertices the bore's mesh carries).
    elasticity: "solid" (the default: the plane mesh extruded into ``layers`` layers of 3D
    tetrahedra) or "plane_stress" (the same plane mesh as first-order plane-stress triangles of
    the wheel's thickness, two coordinates per vertex; ``layers`` is not used; the ports are the
    same; a static member only: the flexible wheels of dynamic runs need the solid).
    """
    mesh_size: float = 0.004
    layers: int = 2
    samples_per_tooth: int = 8
    port_depth: float | None = None
    pillar_holes: HoleSet = HoleSet()
    lightening_holes: HoleSet = HoleSet()
    material: ElasticMaterial | None = None
    bore_ports: int = 0
    elasticity: str = "solid"

    def __post_init__(self):
        check_positive("mesh_size", self.mesh_size)
        check_choice("elasticity", self.elasticity, ELASTICITIES)    # the template lists the choices from it
        b = self.bore_ports
        if isinstance(b, bool) or not isinstance(b, int) or not (b == 0 or 4 <= b <= 64):
            raise RvtoolInputError(f"bore_ports = {b!r} is outside the valid range [0, 64] (integer: 0, the bore's "
                                   "mean motion, or 4 to 64 compression-only patches per crank bore)")
        for nm, lo, hi in (("layers", 1, 16), ("samples_per_tooth", 2, 64)):
            v = getattr(self, nm)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise RvtoolInputError(f"{nm} = {v!r} is outside the valid range [{lo}, {hi}] (integer)")
        if self.port_depth is not None:
            check_nonnegative("port_depth", self.port_depth)


@dataclass(frozen=True, kw_only=True)
class WheelGeometry:
    """Plane geometry of one wheel in its own frame: ``profile`` (a CycloidProfile, turned as the
    wheel's contact law sees it), ``thickness`` [m], ``bores`` ((n, 3): x, y, radius [m]) of the
    crank bores, ``holes`` ((m, 3)) of the pillar holes, ``lightening`` ((l, 3)), the contact
    datum ``port_depth`` [m]."""
    profile: object
    thickness: float
    bores: tuple
    holes: tuple = ()
    lightening: tuple = ()
    port_depth: float = 0.0

    def profile_points(self, samples_per_tooth):
        """(N, 2) profile samples, N = z_g samples_per_tooth, at equal generating-angle steps."""
        n = self.profile.n_teeth * samples_per_tooth
        return np.asarray(self.profile.points(np.linspace(0.0, 2 * np.pi, n, endpoint=False)), float)


@dataclass(frozen=True)
class WheelBody:
    """Parent model of one wheel with named port groups (the public object; module docstring).

    fe: the free :class:`FEModel` (its own ``ports`` empty: the spread ports are here).
    load_matrix P_l and measure_matrix P_m (n_rows, n_dofs) CSR; groups: {name: row indices}
    (``"profile"`` (2 N rows, sample i at rows 2 i, 2 i + 1), ``"bore{k}"``, ``"hole{k}"``, with
    ``spec.bore_ports`` > 0 ``"bore{k}_patches"``: one radial row per patch);
    profile_points (N, 2) [m], profile_normals (N, 2) outward, profile_arc (N,) cumulative arc
    length [m] (closing length ``profile_length``); geometry, spec.
    """
    fe: FEModel
    load_matrix: sp.csr_matrix
    measure_matrix: sp.csr_matrix
    groups: dict
    profile_points: np.ndarray
    profile_normals: np.ndarray
    profile_arc: np.ndarray
    profile_length: float
    geometry: WheelGeometry
    spec: WheelBodySpec

    @property
    def n_profile_ports(self):
        return len(self.profile_points)

    def rows(self, name):
        """Port rows of group ``name``."""
        try:
            return self.groups[name]
        except KeyError:
            raise RvtoolInputError(f"port group {name!r}; valid: {sorted(self.groups)}") from None

    def boundary_vertices(self, names=None):
        """Vertex indices carrying the given groups' patches (default all): the Craig--Bampton or
        floating-frame boundary of these ports."""
        names = sorted(self.groups) if names is None else names
        rows = np.concatenate([self.rows(n) for n in names])
        cols = np.unique(self.load_matrix[rows].indices)
        return np.unique(self.fe.dof_vertex[cols])

    def rigid_readings(self, rows):
        """(n, 3) readings of ports ``rows`` under the wheel's planar rigid motions: unit x and y
        translations and a unit rotation about z through the wheel-frame origin (a patch row reads
        (n_x, n_y, n . (z x c)) of its mean outward normal n)."""
        V = self.fe.vertices
        comp = self.fe.dof_component
        vert = self.fe.dof_vertex
        T = np.zeros((self.fe.n_dofs, 3))
        T[comp == 0, 0] = 1.0
        T[comp == 1, 1] = 1.0
        T[comp == 0, 2] = -V[vert[comp == 0], 1]
        T[comp == 1, 2] = V[vert[comp == 1], 0]
        return np.asarray(self.load_matrix[np.asarray(rows)] @ T)

    def patch_normals(self, k):
        """(N, 2) mean outward normals of crank bore k's patches in the wheel frame (the reading of a
        unit translation; |n| = 1 - O(1/N^2) for a hat-spread patch)."""
        return self.rigid_readings(self.rows(f"bore{k}_patches"))[:, :2]

    @functools.cached_property
    def static_compliance(self):
        """Port compliance C (n_rows, n_rows) [m/N] of the free wheel, sym(P_m K^+ P_l^T), computed
        once per object (one factorization of the bordered inertia-relief system)."""
        u = inertia_relief_solve(self.fe, self.load_matrix.T.toarray())
        C = self.measure_matrix @ u
        return 0.5 * (C + C.T)

    def station_compliance(self, W):
        """(m, m) compliance [m/N] of m stations that combine the port rows, W C W^T with W (m, n_rows)
        (e.g. contacts interpolated on the profile ports, :func:`profile_interpolation`): from
        :attr:`static_compliance` when it is computed, else solved for W's m load vectors only,
        sym(W P_m K^+ P_l^T W^T) (for many profile ports, where the full C would be large)."""
        W = np.atleast_2d(np.asarray(W, float))
        if W.shape[1] != self.load_matrix.shape[0]:
            raise RvtoolInputError(f"W has {W.shape[1]} columns; valid: one per port row ({self.load_matrix.shape[0]})")
        if "static_compliance" in self.__dict__:
            return W @ self.static_compliance @ W.T
        u = inertia_relief_solve(self.fe, np.asarray(self.load_matrix.T @ W.T))
        A = W @ np.asarray(self.measure_matrix @ u)
        return 0.5 * (A + A.T)


def _polygon_area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def plane_mesh(geometry: WheelGeometry, spec: WheelBodySpec):
    """Netgen plane mesh of the section: (points (n, 2), triangles (m, 3), profile (N, 2))."""
    from netgen.geom2d import SplineGeometry
    prof = geometry.profile_points(spec.samples_per_tooth)
    ccw = _polygon_area(prof) > 0
    geo = SplineGeometry()
    ids = [geo.AppendPoint(float(x), float(y)) for x, y in prof]
    n = len(ids)
    left, right = (1, 0) if ccw else (0, 1)
    for i in range(n):
        geo.Append(["line", ids[i], ids[(i + 1) % n]], leftdomain=left, rightdomain=right, bc="profile")
    for k, (x, y, r) in enumerate(tuple(geometry.bores) + tuple(geometry.holes) + tuple(geometry.lightening)):
        geo.AddCircle(c=(float(x), float(y)), r=float(r), leftdomain=0, rightdomain=1, bc=f"circle{k}")
    m = geo.GenerateMesh(maxh=spec.mesh_size)
    pts = np.asarray(m.Coordinates(), float)[:, :2].copy()
    tris = np.asarray(m.Elements2D().NumPy()["nodes"], int)[:, :3] - 1
    return pts, tris, prof


def _extrude(pts, tris, thickness, layers):
    """Points (n (L + 1), 3) and tetrahedra of the prism layers (module docstring)."""
    n = len(pts)
    z = np.linspace(0.0, thickness, layers + 1)
    P = np.concatenate([np.column_stack([pts, np.full(n, zz)]) for zz in z])
    tets = []
    s = np.sort(tris, axis=1)
    for l in range(layers):
        a, b, c = (s[:, j] + l * n for j in range(3))
        A, B, C = a + n, b + n, c + n
        tets += [np.stack(t, axis=1) for t in ((a, b, c, C), (a, b, B, C), (a, A, B, C))]
    T = np.concatenate(tets)
    v = P[T]
    vol = np.einsum("ij,ij->i", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), v[:, 3] - v[:, 0])
    flip = vol < 0
    T[flip, 0], T[flip, 1] = T[flip, 1].copy(), T[flip, 0].copy()
    return P, T


def _ngsolve_mesh(P, T):
    import ngsolve as ngs
    from netgen.meshing import Element3D, FaceDescriptor, Mesh, MeshPoint, Pnt
    m = Mesh(dim=3)
    pid = [m.Add(MeshPoint(Pnt(*map(float, p)))) for p in P]
    m.Add(FaceDescriptor(surfnr=1, domin=1, bc=1))
    m.SetMaterial(1, "wheel")
    for t in T:
        m.Add(Element3D(1, [pid[i] for i in t]))
    return ngs.Mesh(m)


def plane_stress_model(pts, tris, thickness, material: ElasticMaterial, info=None) -> FEModel:
    """Free plane-stress model of a plane mesh (points (n, 2) [m], triangles (m, 3)) of thickness
    ``thickness`` [m]: first-order triangles (NGSolve VectorH1, order 1), generalised plane stress
    (sigma_zz = 0, lambda* = 2 mu lambda / (lambda + 2 mu)), stiffness and mass per unit thickness
    times the thickness. An :class:`FEModel` with vertices (n, 3) at z = 0, two coordinates per vertex
    (x, y interleaved: ``dof_component`` 0 or 1), no tetrahedra."""
    import ngsolve as ngs
    from netgen.meshing import Element2D, FaceDescriptor, Mesh, MeshPoint, Pnt
    tris = np.asarray(tris, int).copy()
    v = pts[tris]
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    neg = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0         # counter-clockwise triangles
    tris[neg, 1], tris[neg, 2] = tris[neg, 2].copy(), tris[neg, 1].copy()
    m = Mesh(dim=2)
    pid = [m.Add(MeshPoint(Pnt(float(x), float(y), 0.0))) for x, y in pts]
    m.Add(FaceDescriptor(surfnr=1, domin=1, bc=1))
    m.SetMaterial(1, "wheel")
    for t in tris:
        m.Add(Element2D(1, [pid[i] for i in t]))
    mesh = ngs.Mesh(m)
    fes = ngs.VectorH1(mesh, order=1)
    nv = len(pts)
    if fes.ndof != 2 * nv:
        raise RvtoolInputError(f"first-order VectorH1 has {fes.ndof} coordinates for {nv} vertices in the plane")
    mu, lam = material.lame()
    lam_ps = 2 * mu * lam / (lam + 2 * mu)
    u, w = fes.TnT()
    eu, ew = ngs.Sym(ngs.Grad(u)), ngs.Sym(ngs.Grad(w))
    a = ngs.BilinearForm(fes)
    a += thickness * (2 * mu * ngs.InnerProduct(eu, ew) + lam_ps * ngs.Trace(eu) * ngs.Trace(ew)) * ngs.dx
    mm = ngs.BilinearForm(fes)
    mm += thickness * material.density * u * w * ngs.dx
    a.Assemble()
    mm.Assemble()
    blocked = np.arange(2 * nv).reshape(2, nv).T.ravel()       # interleaved 2 i + c -> blocked c nv + i
    K = sp.csr_matrix(a.mat.CSR())[blocked][:, blocked]
    M = sp.csr_matrix(mm.mat.CSR())[blocked][:, blocked]
    K = ((K + K.T) * 0.5).tocsr()
    M = ((M + M.T) * 0.5).tocsr()
    n = 2 * nv
    return FEModel(vertices=np.column_stack([pts, np.zeros(nv)]), tetrahedra=np.zeros((0, 4), int),
                   surface_triangles=tris, stiffness=K, elastic_stiffness=K, mass=M, damping=sp.csr_matrix((n, n)),
                   dof_vertex=np.arange(n) // 2, dof_component=np.arange(n) % 2, ports=(),
                   port_matrix=sp.csr_matrix((0, n)), spring_vertices=np.zeros(0, int),
                   clamped_vertices=np.zeros(0, int), damping_coefficients=(0.0, 0.0), material=material,
                   info={"thickness": float(thickness), **(info or {})})


def _boundary_edges(tris):
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    u, cnt = np.unique(e, axis=0, return_counts=True)
    return u[cnt == 1]


def _thickness_weights(layers):
    w = np.ones(layers + 1)
    w[0] = w[-1] = 0.5
    return w / w.sum()


def _tributary(pts, edges, on):
    """Tributary length [m] of each vertex in ``on`` along the boundary edges among them."""
    L = np.zeros(len(pts))
    sel = on[edges[:, 0]] & on[edges[:, 1]]
    le = np.linalg.norm(pts[edges[sel, 0]] - pts[edges[sel, 1]], axis=1)
    np.add.at(L, edges[sel, 0], 0.5 * le)
    np.add.at(L, edges[sel, 1], 0.5 * le)
    return L


def _barycentric(pts, tris, q):
    """(triangle vertex indices (3,), weights (3,)) of the plane mesh at point q."""
    v = pts[tris]
    d = np.linalg.norm(v.mean(axis=1) - q, axis=1)
    for t in np.argsort(d)[:64]:
        a, b, c = v[t]
        M = np.column_stack([b - a, c - a])
        l12 = np.linalg.solve(M, q - a)
        w = np.array([1 - l12.sum(), l12[0], l12[1]])
        if w.min() >= -1e-9:
            return tris[t], np.clip(w, 0.0, None) / np.clip(w, 0.0, None).sum()
    raise RvtoolInputError(f"port point {q.tolist()} lies outside the wheel section; port_depth is larger than "
                           "the material below the flank (valid: a depth inside the rim)")


def wheel_body(geometry: WheelGeometry, spec: WheelBodySpec, material: ElasticMaterial) -> WheelBody:
    """Mesh, assemble and port one wheel (module docstring)."""
    check_positive("thickness", geometry.thickness)
    pts, tris, prof = plane_mesh(geometry, spec)
    n2 = len(pts)
    if spec.elasticity == "plane_stress":
        # one plane of vertices, two coordinates each (x, y interleaved): the ports' "layers" are that plane
        L, nc = 0, 2
        fe = plane_stress_model(pts, tris, geometry.thickness, material,
                                info={"component": "cycloid wheel (plane stress)", "mesh_size": spec.mesh_size})
        wz = np.ones(1)
    else:
        L, nc = spec.layers, 3
        P3, T = _extrude(pts, tris, geometry.thickness, L)
        fe = fe_model_from_mesh(_ngsolve_mesh(P3, T), material=material,
                                info={"component": "cycloid wheel", "mesh_size": spec.mesh_size, "layers": L})
        wz = _thickness_weights(L)
    ndof = fe.n_dofs
    edges = _boundary_edges(tris)
    bnd = np.zeros(n2, bool)
    bnd[edges.ravel()] = True

    # profile: arc parameter of every boundary vertex on the polyline
    N = len(prof)
    seg = np.roll(prof, -1, axis=0) - prof
    seg_len = np.linalg.norm(seg, axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
    total = float(seg_len.sum())
    tang = seg / seg_len[:, None]
    t_node = np.roll(tang, 1, axis=0) + tang
    t_node /= np.linalg.norm(t_node, axis=1)[:, None]
    ccw = _polygon_area(prof) > 0
    normals = np.column_stack([t_node[:, 1], -t_node[:, 0]]) * (1.0 if ccw else -1.0)   # outward
    # distance of boundary vertices to the polyline segments
    s_of = np.full(n2, np.nan)
    cand = np.flatnonzero(bnd)
    for v in cand:
        p = pts[v]
        t = np.clip(np.einsum("ij,ij->i", p - prof, seg) / seg_len ** 2, 0.0, 1.0)
        dist = np.linalg.norm(prof + t[:, None] * seg - p, axis=1)
        i = int(np.argmin(dist))
        if dist[i] < 1e-9 * total + 1e-12:
            s_of[v] = arc[i] + t[i] * seg_len[i]
    on_prof = np.isfinite(s_of)
    trib = _tributary(pts, edges, on_prof)

    rows_i, cols_i, vals = [], [], []
    mrows, mcols, mvals = [], [], []

    def add(rows, cols, vals_, r, vert2d, w):
        for layer in range(L + 1):
            for c in range(2):
                rows.extend([r + c] * len(vert2d))
                cols.extend(nc * (vert2d + layer * n2) + c)
                vals_.extend(w * wz[layer])

    pv = np.flatnonzero(on_prof)
    for i in range(N):
        # hat over [arc_{i-1}, arc_{i+1}] (periodic)
        ds = (s_of[pv] - arc[i] + 0.5 * total) % total - 0.5 * total
        h_lo = seg_len[i - 1]
        h_hi = seg_len[i]
        hat = np.where(ds < 0, 1 + ds / h_lo, 1 - ds / h_hi)
        sel = hat > 1e-12
        w = hat[sel] * trib[pv[sel]]
        add(rows_i, cols_i, vals, 2 * i, pv[sel], w / w.sum())
    groups = {"profile": np.arange(2 * N)}
    r0 = 2 * N
    circles = [(f"bore{k}", c) for k, c in enumerate(geometry.bores)] + \
              [(f"hole{k}", c) for k, c in enumerate(geometry.holes)]
    for name, (x, y, rad) in circles:
        d = np.abs(np.linalg.norm(pts - np.array([x, y]), axis=1) - rad)
        on = bnd & (d < 1e-6 * rad + 1e-3 * spec.mesh_size)
        w = _tributary(pts, edges, on)[on]
        add(rows_i, cols_i, vals, r0, np.flatnonzero(on), w / w.sum())
        groups[name] = np.arange(r0, r0 + 2)
        r0 += 2
    nbp = spec.bore_ports
    for k, (x, y, rad) in enumerate(geometry.bores if nbp else ()):
        d = np.abs(np.linalg.norm(pts - np.array([x, y]), axis=1) - rad)
        on = bnd & (d < 1e-6 * rad + 1e-3 * spec.mesh_size)
        vs = np.flatnonzero(on)
        if len(vs) < nbp:
            raise RvtoolInputError(f"wheels.structure.bore_ports = {nbp} is more than crank bore {k}'s mesh carries "
                                   f"({len(vs)} vertices on the bore at mesh_size = {spec.mesh_size} m); valid range "
                                   f"[4, {len(vs)}] at this mesh, or a smaller mesh_size")
        trib = _tributary(pts, edges, on)[vs]
        rel = pts[vs] - np.array([x, y])
        nv = rel / np.linalg.norm(rel, axis=1)[:, None]
        psi = np.arctan2(rel[:, 1], rel[:, 0])
        step = 2 * np.pi / nbp
        for i in range(nbp):
            dpsi = (psi - i * step + np.pi) % (2 * np.pi) - np.pi
            hat = np.clip(1.0 - np.abs(dpsi) / step, 0.0, None)
            sel = hat > 1e-12
            w = hat[sel] * trib[sel]
            w = w / w.sum()
            for layer in range(L + 1):
                for c in range(2):
                    rows_i.extend([r0 + i] * int(sel.sum()))
                    cols_i.extend(nc * (vs[sel] + layer * n2) + c)
                    vals.extend(w * nv[sel, c] * wz[layer])
        groups[f"bore{k}_patches"] = np.arange(r0, r0 + nbp)
        r0 += nbp
    n_rows = r0
    # the dofs are node-interleaved over all vertices (no clamps): dof = nc vertex + component (nc = 3, or 2 in
    # plane stress)
    Pl = sp.csr_matrix((vals, (rows_i, cols_i)), shape=(n_rows, ndof))
    depth = geometry.port_depth
    if depth > 0:
        for i in range(N):
            tv, bw = _barycentric(pts, tris, prof[i] - depth * normals[i])
            add(mrows, mcols, mvals, 2 * i, tv, bw)
        Pd = sp.csr_matrix((mvals, (mrows, mcols)), shape=(2 * N, ndof))
        # the normal component measured at depth, the tangential one on the surface (the contact law
        # holds the normal approach only)
        nn = sp.block_diag([np.outer(n_, n_) for n_ in normals])
        tt = sp.block_diag([np.eye(2) - np.outer(n_, n_) for n_ in normals])
        Pm = sp.vstack([nn @ Pd + tt @ Pl[:2 * N], Pl[2 * N:]]).tocsr()
    else:
        Pm = Pl
    return WheelBody(fe=fe, load_matrix=Pl, measure_matrix=Pm.tocsr(), groups=groups, profile_points=prof,
                     profile_normals=normals, profile_arc=arc, profile_length=total, geometry=geometry, spec=spec)


def inertia_relief_solve(fe: FEModel, f):
    """Displacements u (n, k) [m] of the free body ``fe`` under loads f (n, k) [N] in inertia relief:
    the rigid part of f is balanced by the rigid-body inertia, f~ = f - M R (R^T M R)^-1 R^T f, the
    body is held by a statically determinate 3-2-1 support (no reaction for a balanced load), and the
    answer is made mass-orthogonal to the rigid modes R (six), u = (I - R (R^T M R)^-1 R^T M) u_s:
    the bordered system of :class:`~rvtool.structure.static.InertiaReliefCompliance` without its
    dense border (which fills the sparse factor)."""
    from .craig_bampton import factorize
    K, M = fe.elastic_stiffness, fe.mass
    R = fe.rigid_body_modes(centre=fe.vertices.mean(axis=0))
    planar = int(fe.dof_component.max()) < 2
    if planar:                                   # plane stress: x, y and the rotation about z
        R = R[:, [0, 1, 5]]
    MR = np.asarray(M @ R)
    A = np.linalg.inv(R.T @ MR)
    f = np.asarray(f, float)
    ft = f - MR @ (A @ (R.T @ f))
    # 3-2-1: vertex a all three, b (far from a) two, c (off the line a-b) one
    V = fe.vertices
    a = int(np.argmin(V[:, 0]))
    b = int(np.argmax(np.linalg.norm(V - V[a], axis=1)))
    ab = (V[b] - V[a]) / np.linalg.norm(V[b] - V[a])
    off = np.linalg.norm(np.cross(V - V[a], ab), axis=1)
    c = int(np.argmax(off))
    ax = int(np.argmax(np.abs(ab)))
    if planar:                                   # 2-1: vertex a both, b the coordinate across a-b
        held = [2 * a, 2 * a + 1, 2 * b + (1 - ax)]
    else:
        held = [3 * a, 3 * a + 1, 3 * a + 2] + [3 * b + j for j in range(3) if j != ax] + [3 * c + 2]
    free = np.setdiff1d(np.arange(fe.n_dofs), held)
    lu = factorize(K[free][:, free], "K of the wheel on its 3-2-1 support")
    u = np.zeros_like(ft)
    u[free] = lu.solve(ft[free])
    return u - R @ (A @ (MR.T @ u))


def profile_interpolation(wb: WheelBody, points):
    """(W (2 n, 2 N) dense, s (n,) arc parameters [m]) interpolating the profile ports at the flank
    points nearest to ``points`` (n, 2) (wheel frame): the linear hat weights of the two samples
    around each point, the same on x and y."""
    pts = np.atleast_2d(np.asarray(points, float))
    prof = wb.profile_points
    N = len(prof)
    seg = np.roll(prof, -1, axis=0) - prof
    l2 = np.einsum("ij,ij->i", seg, seg)
    # every point against every segment at once (the same arithmetic per pair as one point at a time)
    d = pts[:, None, :] - prof[None, :, :]                                          # (n, N, 2)
    t = np.clip((d[..., 0] * seg[:, 0] + d[..., 1] * seg[:, 1]) / l2, 0.0, 1.0)     # (n, N)
    e = prof[None] + t[..., None] * seg[None] - pts[:, None, :]
    i = np.argmin(np.sqrt(e[..., 0] ** 2 + e[..., 1] ** 2), axis=1)
    j = (i + 1) % N
    ti = t[np.arange(len(pts)), i]
    W = np.zeros((2 * len(pts), 2 * N))
    k = np.arange(len(pts))
    for c in range(2):
        np.add.at(W, (2 * k + c, 2 * i + c), 1.0 - ti)
        np.add.at(W, (2 * k + c, 2 * j + c), ti)
    return W, wb.profile_arc[i] + ti * np.sqrt(l2[i])
