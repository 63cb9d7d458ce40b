"""WORK IN PROGRESS, not a case yet (the leading underscore keeps it out of ``rvtool list`` and the quick suite):
the elastic cycloid wheel body (issue 30) against an independent 2D plane-stress contact model of one wheel.

State (2026-11-27): the reduced side runs (rv40e, 6 mm / 4 ports per tooth: 3.71e-5 rad at T_w = 206 N m, the
local contact 37 % of it). The reference has not produced a figure yet: with the flank sampled every 5 um near the
contacts (straight segments) its Newton solve converged only with the penalty continuation below and cost ~30 s per
step on the shared machine; with curved (spline3) segments and h_c = 40 um, Netgen's plane meshing did not finish in
7 minutes. To finish: a reference mesh built directly (a structured refinement around each contact), a quick mode
under 300 s, then rename to ``wheel_body_contact.py`` with its row in README.md.

Problem (both models, rv40e's wheel 0 in its own frame at input angle 0): the ring pins are rigid and fixed; rigid
journals (the crank eccentrics with their needle sets taken rigid) sit in the crank bores without clearance and turn
together by theta about the wheel centre; the wheel is free and finds its place between them. The wheel twist at
the wheel torque T_w = T_R / 2 (the rated output torque shared by the two wheels; a stated load case, not a model
output) is theta at the journals' torque T_w about the wheel centre.

* Reference: NGSolve plane stress (second-order triangles, thickness = wheels.width) with penalty contact of the
  wheel's flank against each rigid pin and of each bore against its rigid journal (compression only), solved by
  Newton's method in load steps. The flank near every contact is sampled every 5 um (kinks below 1e-3 rad) and
  meshed at h_c, a fraction of the Hertz half-width; the penalty (1e18 N/m^3) leaves 0.1 % of the approach.
* Reduced member: the wheel body of rvtool (``rvtool.assembly.wheel_body.wheel_model``: 3D tetrahedra, spread
  ports, the profile ports measuring the normal displacement at the datum depth d = r_p) for the body, and for the
  local contact of each rigid pin the plane-stress Hertz approach from the surface to the depth d (Johnson, Contact
  Mechanics, 1985, Sec. 5.6, Eq. (5.39)-type: delta = P/(pi E) [2 ln(2 d / a) - nu], a^2 = 4 P R / (pi E), P per unit
  width; plane stress: E for E/(1 - nu^2)); contacts interpolated on the profile ports, bores tied to their journals
  through the bore ports, active set and Newton on the nonlinear law.

The check: |theta_reduced / theta_reference - 1| <= 5 % (issue 30's target). Also reported: the local share of the
twist and the twist with the FE's near field counted twice (ports measured on the surface, ``port_depth = 0``).

--quick: the wheel at 6 mm / 4 ports per tooth, the reference at h_c = 15 um; full: the design's wheel mesh and
h_c = 8 um.
"""
import dataclasses
import math
import time

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.assembly.wheel_body import wheel_geometry, wheel_model
from rvtool.geometry.cycloid import pin_centres
from rvtool.structure.wheel_body import WheelBodySpec, profile_interpolation, wheel_body

BOUND = 0.05
"""Issue 30: the wheel body within 5 % of the 2D contact model at T_R."""
PENALTY = 1e18
"""N/m^3: penalty approach p / kappa at the ~2 GPa Hertz peak is 2e-9 m, 0.1 % of the ~2e-6 m contact approach."""
VERBOSE = False
ZONE = 0.25e-3
"""m: half-length of the flank window meshed at h_c around every candidate contact (4 Hertz half-widths)."""
GAP_CANDIDATE = 20e-6
"""m: pins whose zero-load gap is below this and whose normal resists the twist are contact candidates."""


def setup(design):
    model = rvtool.build(design)
    wc = np.asarray(model.reference[model.layout.wheel(0), :2], float)
    prof = wheel_geometry(design, 0).profile
    pins = pin_centres(prof) - wc                      # wheel frame (the wheel's angle is 0 at input 0)
    zg = prof.n_teeth
    phi = np.linspace(0, 2 * np.pi, 2000 * zg, endpoint=False)
    P = prof.points(phi)
    cand = []
    for k, c in enumerate(pins):
        d = np.linalg.norm(P - c, axis=1)
        i = int(np.argmin(d))
        # refine the closest point on the analytic curve
        ph = np.linspace(phi[i - 1], phi[(i + 1) % len(phi)] if i + 1 < len(phi) else 2 * np.pi, 201)
        dd = np.linalg.norm(prof.points(ph) - c, axis=1)
        j = int(np.argmin(dd))
        p = prof.points(ph[j])
        n = (c - p) / np.linalg.norm(c - p)              # outward normal of the wheel at the contact
        gap = float(dd[j] - design.pins.pin_radius)
        lever = float(n[0] * (-p[1]) + n[1] * p[0]) / np.linalg.norm(p)   # n . (z x p) / |p|
        if gap < GAP_CANDIDATE and lever > 0.05:
            cand.append({"pin": k, "phi": float(ph[j]), "point": p, "normal": n, "gap": max(gap, 0.0),
                         "curvature": float(prof.curvature_of_points(ph[j]))})
    return prof, pins, cand


def hertz_local(F, width, E, nu, R, depth):
    """Plane-stress approach [m] of the surface to the datum depth under a rigid cylinder (module docstring) and its
    derivative d delta / dF [m/N]."""
    P = F / width
    a = math.sqrt(4 * P * R / (math.pi * E))
    d = P / (math.pi * E) * (2 * math.log(2 * depth / a) - nu)
    dd = (2 * math.log(2 * depth / a) - nu - 1.0) / (math.pi * E * width)
    return d, dd


def reduced_twist(design, wb, pins, cand, torque):
    """(theta [rad], pin forces (nc,) [N], local approaches (nc,) [m]) of the reduced member at journal torque
    ``torque`` [N m] (module docstring). Unknowns x = (F (nc), f_b (2 n_b), w (3)): pin forces, the journals'
    forces on the wheel, the wheel's rigid motion; equations: the gap of every active pin (F = 0 for the others),
    the bores on their journals, the wheel's balance."""
    E, nu = design.material.youngs_modulus, design.material.poisson_ratio
    t, rp, depth = design.wheels.width, design.pins.pin_radius, wb.geometry.port_depth
    C = wb.static_compliance
    nc, nb = len(cand), len(wb.geometry.bores)
    bores = np.array([b[:2] for b in wb.geometry.bores])
    W, _ = profile_interpolation(wb, np.array([pins[c["pin"]] for c in cand]))
    Wf = np.zeros((2 * nc + 2 * nb, C.shape[0]))
    Wf[:2 * nc, wb.rows("profile")] = W
    for b in range(nb):
        Wf[2 * nc + 2 * b + np.arange(2), wb.rows(f"bore{b}")] = 1.0
    Cs = Wf @ C @ Wf.T
    pts = np.vstack([np.array([c["point"] for c in cand]), bores])
    G = np.zeros((2 * len(pts), 3))                      # rigid motion (w_x, w_y, w_theta) at the stations
    G[0::2, 0] = G[1::2, 1] = 1.0
    G[0::2, 2], G[1::2, 2] = -pts[:, 1], pts[:, 0]
    A = np.zeros((2 * nc + 2 * nb, nc + 2 * nb))       # station forces on the wheel from (F, f_b)
    for i, c in enumerate(cand):
        A[2 * i:2 * i + 2, i] = -c["normal"]
    A[2 * nc:, nc:] = np.eye(2 * nb)
    D = np.hstack([Cs @ A, G])                           # station displacements per unknown
    Nrm = np.zeros((nc, 2 * nc + 2 * nb))
    for i, c in enumerate(cand):
        Nrm[i, 2 * i:2 * i + 2] = c["normal"]
    gap0 = np.array([c["gap"] for c in cand])
    Rrel = np.array([1.0 / (1.0 / rp + c["curvature"]) for c in cand])
    bal = G.T @ A                                        # resultant and moment of the station forces
    n_u = nc + 2 * nb + 3

    def solve(theta):
        rot = np.array([[math.cos(theta) - 1, -math.sin(theta)], [math.sin(theta), math.cos(theta) - 1]])
        dj = (bores @ rot.T).ravel()
        active = np.ones(nc, bool)
        x = np.zeros(n_u)
        x[:nc] = 1.0
        for _ in range(40):
            for _it in range(50):
                F = np.maximum(x[:nc], 1e-9)
                loc = np.array([hertz_local(F[i], t, E, nu, Rrel[i], depth) for i in range(nc)])
                disp = D @ x
                r = np.zeros(n_u)
                J = np.zeros((n_u, n_u))
                g = gap0 - Nrm @ disp + loc[:, 0]             # geometric gap + local approach = 0
                r[:nc] = np.where(active, g, x[:nc])
                J[:nc] = np.where(active[:, None], -Nrm @ D, 0.0)
                J[np.arange(nc), np.arange(nc)] += np.where(active, loc[:, 1], 1.0)
                r[nc:nc + 2 * nb] = disp[2 * nc:] - dj
                J[nc:nc + 2 * nb] = D[2 * nc:]
                r[nc + 2 * nb:] = bal @ x[:nc + 2 * nb]
                J[nc + 2 * nb:, :nc + 2 * nb] = bal
                dx = np.linalg.solve(J, -r)
                x = x + dx
                x[:nc] = np.where(active, np.maximum(x[:nc], 1e-9), 0.0)
                if np.abs(dx[:nc]).max() <= 1e-10 * max(1.0, np.abs(x[:nc]).max()):
                    break
            F = x[:nc]
            loc = np.array([hertz_local(max(F[i], 1e-9), t, E, nu, Rrel[i], depth)[0] for i in range(nc)])
            g = gap0 - Nrm @ (D @ x)                        # geometric gap (a contact's is -its approach)
            new = active & (F > 1e-6 * max(1.0, F.max()))
            new |= ~active & (g < -1e-12)
            if np.array_equal(new, active):
                break
            x[:nc] = np.where(new & ~active, 1e-3, np.where(new, x[:nc], 0.0))
            active = new
        fb = x[nc:nc + 2 * nb].reshape(nb, 2)
        T = float(np.sum(bores[:, 0] * fb[:, 1] - bores[:, 1] * fb[:, 0]))
        return T, np.where(active, x[:nc], 0.0), np.where(active, loc, 0.0)

    theta = 1e-4
    for _ in range(12):
        T, F, loc = solve(theta)
        new = theta * torque / T
        if abs(new / theta - 1) < 1e-9:
            break
        theta = new
    return theta, F, loc


def reference_twist(design, prof, pins, cand, torque, h_c, quick):
    """theta [rad] of the 2D plane-stress contact model at journal torque ``torque`` [N m] (module docstring)."""
    import ngsolve as ngs
    from netgen.geom2d import SplineGeometry
    E, nu, t = design.material.youngs_modulus, design.material.poisson_ratio, design.wheels.width
    rp = design.pins.pin_radius
    geo_w = wheel_geometry(design, 0)
    zg = prof.n_teeth
    # the flank as curved (rational quadratic) segments between samples, 32 per tooth plus the ends of a
    # +-ZONE window around every candidate contact, meshed at h_c inside the windows
    base = np.linspace(0, 2 * np.pi, 32 * zg, endpoint=False)
    speed = np.linalg.norm(prof.epitrochoid(np.array([c["phi"] for c in cand]))[1], axis=-1)
    win = [(c["phi"] - ZONE / v, c["phi"] + ZONE / v) for c, v in zip(cand, speed)]
    phi = np.concatenate([base, np.ravel(win), [c["phi"] for c in cand]])
    phi = np.unique(np.mod(phi, 2 * np.pi))
    base_ok = np.ones(len(phi), bool)
    for lo, hi in win:                                    # no base samples inside a window (its own segments)
        inside = (phi > lo + 1e-12) & (phi < hi - 1e-12)
        keep_c = np.isclose(phi, 0.5 * (lo + hi), atol=1e-12)
        base_ok &= ~inside | keep_c
    phi = phi[base_ok]
    h = 1e-7
    P = prof.points(phi)
    T = (prof.points(phi + h) - prof.points(phi - h)) / (2 * h)
    geo = SplineGeometry()
    n = len(phi)
    pid = [geo.AppendPoint(float(x), float(y)) for x, y in P]
    for i in range(n):
        j = (i + 1) % n
        # control point: intersection of the tangents at both ends
        A = np.column_stack([T[i], -T[j]])
        st = np.linalg.solve(A, P[j] - P[i])
        c = P[i] + st[0] * T[i]
        cid = geo.AppendPoint(float(c[0]), float(c[1]))
        mid = phi[i] + 0.5 * ((phi[j] - phi[i]) % (2 * np.pi))
        owner = [k for k, (lo, hi) in enumerate(win) if lo - 1e-12 <= mid <= hi + 1e-12 or
                 lo - 1e-12 <= mid - 2 * np.pi <= hi + 1e-12]
        bc = f"pin{owner[0]}" if owner else "free"
        kw = {"maxh": h_c} if owner else {}
        geo.Append(["spline3", pid[i], cid, pid[j]], leftdomain=0, rightdomain=1, bc=bc, **kw)
    for b, (x, y, r) in enumerate(geo_w.bores):
        geo.AddCircle(c=(float(x), float(y)), r=float(r), leftdomain=0, rightdomain=1, bc=f"bore{b}",
                      maxh=r / (12 if quick else 24))
    mesh = ngs.Mesh(geo.GenerateMesh(maxh=3e-3 if quick else 2e-3, grading=0.2))
    mesh.Curve(2)
    fes = ngs.VectorH1(mesh, order=2)
    if VERBOSE:
        print("reference mesh", mesh.ne, fes.ndof, flush=True)
    u = fes.TrialFunction()
    gfu = ngs.GridFunction(fes)
    X = ngs.CF((ngs.x, ngs.y))
    eps = ngs.Sym(ngs.Grad(u))
    W = 0.5 * t * E / (1 - nu ** 2) * ((1 - nu) * ngs.InnerProduct(eps, eps) + nu * ngs.Trace(eps) ** 2)
    theta_p = ngs.Parameter(0.0)
    kappa = ngs.Parameter(PENALTY)
    a = ngs.BilinearForm(fes, symmetric=True)
    a += ngs.Variation(W * ngs.dx)
    a += ngs.Variation(1e-6 * E / 0.1 ** 2 * t * 0.5 * u * u * ngs.dx)      # removes the free wheel's rigid modes

    def penalty(centre, radius):
        d = X + u - centre
        g = ngs.sqrt(d * d) - radius
        return 0.5 * kappa * t * ngs.IfPos(-g, g * g, 0)
    for k, c in enumerate(cand):
        a += ngs.Variation(penalty(ngs.CF(tuple(map(float, pins[c["pin"]]))), rp) * ngs.ds(f"pin{k}"))
    bores = np.array([b[:2] for b in geo_w.bores])
    for b, (x, y) in enumerate(bores):
        cx = ngs.cos(theta_p) * x - ngs.sin(theta_p) * y
        cy = ngs.sin(theta_p) * x + ngs.cos(theta_p) * y
        a += ngs.Variation(penalty(ngs.CF((cx, cy)), geo_w.bores[b][2]) * ngs.ds(f"bore{b}"))

    def newton(scale):
        """Newton's method with a backtracking line search on the energy (the problem is a minimization);
        stops when the Newton decrement du . res falls below 1e-13 of the work scale T theta [J]."""
        res = gfu.vec.CreateVector()
        du = gfu.vec.CreateVector()
        trial = gfu.vec.CreateVector()
        for it in range(80):
            a.Apply(gfu.vec, res)
            a.AssembleLinearization(gfu.vec)
            inv = a.mat.Inverse(fes.FreeDofs(), inverse="umfpack")
            du.data = inv * res
            err = abs(ngs.InnerProduct(du, res))
            if VERBOSE:
                print("newton", it, err, flush=True)
            if err < 1e-13 * scale:
                return it
            e0 = a.Energy(gfu.vec)
            step = 1.0
            for _ in range(30):
                trial.data = gfu.vec - step * du
                if a.Energy(trial) <= e0:
                    break
                step *= 0.5
            gfu.vec.data = trial
        raise RuntimeError("the reference contact solve did not converge in 80 Newton steps")

    def journal_torque():
        tq = 0.0
        for b, (x, y) in enumerate(bores):
            c = ngs.CF((ngs.cos(theta_p) * x - ngs.sin(theta_p) * y, ngs.sin(theta_p) * x + ngs.cos(theta_p) * y))
            d = X + gfu - c
            r = ngs.sqrt(d * d)
            g = r - geo_w.bores[b][2]
            f = -kappa * t * ngs.IfPos(-g, g, 0) * d / r            # force on the wheel (outward push)
            pos = X + gfu
            tq += ngs.Integrate(pos[0] * f[1] - pos[1] * f[0], mesh, ngs.BND, definedon=mesh.Boundaries(f"bore{b}"))
        return float(tq)

    # penalty continuation from 1e-3 of the final penalty (soft contacts: the Newton steps stay in the region
    # where the penalty's Hessian is definite), each level from the last one's solution
    theta, iters = 3e-5, []
    theta_p.Set(theta)
    for k in (1e-3, 1e-2, 1e-1, 1.0):
        kappa.Set(PENALTY * k)
        iters.append(newton(torque * theta))
    for _ in range(6):
        T = journal_torque()
        new = theta * torque / T
        if abs(new / theta - 1) < 1e-7:
            break
        gfu.vec.data *= new / theta                      # near-linear: the scaled solution as the next guess
        theta = new
        theta_p.Set(theta)
        iters.append(newton(torque * theta))
    T = journal_torque()
    return theta * torque / T, {"elements": int(mesh.ne), "dofs": int(fes.ndof), "newton_iterations": iters,
                                "h_contact_m": h_c}


def judge(r):
    return {"wheel_twist_vs_reference": casekit.check(r["rel_err"], BOUND, "<=",
                                                      "issue 30: the reduced wheel body within 5 % of the 2D "
                                                      "plane-stress contact model at T_R")}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    design = rvtool.load_design(designs.path("rv40e"))
    spec = {"mesh_size": 0.006, "samples_per_tooth": 4} if args.quick else {}
    d = design.replace(wheels={"body": "ported", "structure": spec})
    prof, pins, cand = setup(d)
    torque = 0.5 * d.rated_torque
    wb = wheel_model(d, 0)
    th_red, F_red, local = reduced_twist(d, wb, pins, cand, torque)
    # the same wheel with its ports on the surface: the FE's near field counted a second time
    geo0 = dataclasses.replace(wb.geometry, port_depth=0.0)
    wb0 = wheel_body(geo0, wb.spec, wb.fe.material)
    th_dbl = reduced_twist(d, wb0, pins, cand, torque)[0]
    h_c = 40e-6 if args.quick else 15e-6
    th_ref, ref_info = reference_twist(d, prof, pins, cand, torque, h_c, args.quick)
    active = F_red > 0
    local_work = float(np.sum(F_red * local))           # the local approaches' work against the journals' (T theta)
    results = {"wheel_torque_Nm": torque, "theta_reference_rad": th_ref, "theta_reduced_rad": th_red,
               "rel_err": abs(th_red / th_ref - 1.0), "theta_surface_ports_rad": th_dbl,
               "surface_ports_rel_err": abs(th_dbl / th_ref - 1.0),
               "local_contact_share_of_twist": local_work / (torque * th_red),
               "contacts_candidates": len(cand), "contacts_active_reduced": int(active.sum()),
               "reduced_mesh": wb.fe.counts(), "reference": ref_info,
               "stiffness_reference_Nm_per_arcmin": torque / th_ref * math.pi / (180 * 60),
               "stiffness_reduced_Nm_per_arcmin": torque / th_red * math.pi / (180 * 60)}
    casekit.verdict(results, judge)
    settings = {"quick": args.quick, "design": "rv40e", "wheel": 0, "penalty_N_per_m3": PENALTY,
                "gap_candidate_m": GAP_CANDIDATE, "wheel_spec": dataclasses.asdict(wb.spec)}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
