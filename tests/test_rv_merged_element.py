"""One contact element per Exudyn system for the RV and small-tooth-difference builders (issue 19
Deliver 3, issue 16): ``build(..., contact_element="merged" | "per_family")`` of
:mod:`rvtool.assembly.rv` and :mod:`rvtool.assembly.std_involute`.

References: central differences of the merged element's generalized forces (the tangent it hands
to Exudyn) at the rv40e rated state; the per-family layout (one Exudyn element per family, the
former build) on the same design, which the merged layout must reproduce to round-off: the
families, rows and physics are the same, only the order in which the families' generalized
forces are summed differs (relative round-off ~1e-16 of each force).
"""
import numpy as np
import pytest

from rvtool import designs
from rvtool.solver.static import StaticSolver

ARCSEC = 180 / np.pi * 3600


def _rv(**changes):
    from rvtool.assembly.rv import load_design
    d = load_design(designs.path("rv40e"))
    return d.replace(**changes) if changes else d


def _loaded(build, mode, d, angle=0.0):
    m = build(d, contact_element=mode)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    s = StaticSolver(m)
    return m, s.solve(angle), s


def _same_observation(a, b):
    """Same ids and rows; every column compared on the loaded rows. An unloaded row's contact point
    and normal are the direction of a ~1e-12 m centre offset (the STD main bearing at rated load),
    which round-off turns freely, so there only the (zero) normal force is compared."""
    from warp_contacts.circle_pairs_ref import O_FN
    assert a.ids == b.ids
    tol = 1e-9 * max(b.peak, 1.0)
    assert np.allclose(a.obs[:, O_FN], b.obs[:, O_FN], rtol=1e-9, atol=tol)
    loaded = b.obs[:, O_FN] > 0
    assert np.allclose(a.obs[loaded], b.obs[loaded], rtol=1e-9, atol=tol)


@pytest.fixture(scope="module")
def rv40e():
    from rvtool.assembly.rv import build
    d = _rv()
    return d, _loaded(build, "merged", d), _loaded(build, "per_family", d)


def test_merged_rv_tangent_matches_central_differences(rv40e):
    """dQ/dq and dQ/dq_t of all RV families together (pins, involute stage, needles, tapered crank
    pairs, main bearing: the Jacobian callback's content) vs central differences at the rv40e
    rated state with a random velocity (contact damping active). h = 1e-9 m / 1e-8 rad: truncation
    h^2 Q''' and round-off eps Q / h both ~1e-7 relative; tolerance 1e-5 (as for the cycloid host
    and the per-family RV elements, tests/test_rv.py)."""
    d, (m, q, _), _ = rv40e
    host = m.contact_host
    assert host is not None and not host.sparse          # 7 bodies, 21 coordinates: dense hand-over
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(4).normal(0, 1e-4, ql.shape)
    n = len(ql)
    K, D = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        h = 1e-8 if j % 3 == 2 else 1e-9
        for M, arg in ((K, 0), (D, 1)):
            xp, xm = [ql.copy(), vl.copy()], [ql.copy(), vl.copy()]
            xp[arg][j] += h
            xm[arg][j] -= h
            M[:, j] = (host.evaluate(10.0 + j + 0.25 * arg, *xp)[0] - host.evaluate(20.0 + j + 0.25 * arg, *xm)[0]) / (2 * h)
    J = host.tangent(0.0, ql, vl, 1.0, 0.0)
    Jv = host.tangent(0.0, ql, vl, 0.0, 1.0)
    assert np.linalg.norm(J) > 1e7                       # loaded contacts: stiffness of 10 N/um order
    assert np.linalg.norm(J - K) / np.linalg.norm(K) < 1e-5
    assert np.linalg.norm(Jv - D) / np.linalg.norm(D) < 1e-5
    # the Exudyn callback returns -(f_q dQ/dq + f_v dQ/dq_t) (Exudyn's ObjectGenericODE2 convention)
    cb = host.jacobian_callback(m.mbs, 0.0, host.object_number, ql, vl, 0.7, 0.3)
    assert np.allclose(np.asarray(cb), -(0.7 * J + 0.3 * Jv), rtol=0, atol=1e-12 * np.abs(J).max())


def test_merged_and_per_family_rv_rated_equilibria_agree(rv40e):
    """One Exudyn contact object instead of five; the same rated equilibrium, Newton count and
    per-family observations. Tolerance 1e-10 of the largest displacement: both solves take the
    same Newton path from the same start and their residuals differ by summation-order round-off
    (~1e-13 N or N m on contact forces of 1e3 N), which the softest direction of the free play (a
    regularization spring of 0.1 N m/rad) turns into ~1e-12 rad (measured 6.3e-16 m / rad against
    2.7e-4: 2.3e-12 relative); an error in a family's rows or coordinates would be O(1)."""
    d, (m, q, s), (m0, q0, s0) = rv40e
    assert set(m.elements) == set(m0.elements)
    assert {el.object_number for el in m.elements.values()} == {m.contact_host.object_number}
    assert m0.contact_host is None and len({el.object_number for el in m0.elements.values()}) == len(m0.elements)
    assert np.max(np.abs(q - q0)) <= 1e-10 * np.max(np.abs(q0))
    assert s.stats.newton_iterations == s0.stats.newton_iterations
    for fam in m.families:
        _same_observation(m.observe(q, fam), m0.observe(q0, fam))
    assert np.allclose(m.crank_load_share(q), m0.crank_load_share(q0), rtol=0, atol=1e-10)


@pytest.mark.parametrize("variant", ["elastic_cranks", "anchor_friction"])
def test_every_rv_evaluator_in_the_merged_element(variant):
    """Elastic cranks (the stacked involute + needle set closed by the crank beams, evaluated on the
    host; the stack takes history-free parts only, so anchor friction is the other variant),
    Palmgren bearing friction (loss elements reading their bearing sets' accepted loads), anchor
    friction on the involute stage (committed history) and gap offsets on the pins: the
    rated equilibrium, a gap-offset re-solve and 20 dynamic steps equal the per-family layout's to
    round-off (same step and Newton counts; TE to 1e-9 arcsec against TE of arcseconds; states to
    1e-10 of the largest displacement, as in the rated-state test)."""
    from rvtool.assembly.rv import build
    from rvtool.protocols.precision import dynamic_te
    from rvtool.solver import RunSpec
    if variant == "elastic_cranks":
        d = _rv(cranks={"shaft": {"model": "simply_supported"}}, bearing_friction={"model": "palmgren"})
        path = {"cranks"}
    else:
        d = _rv(involute_stage={"mu": 0.05, "friction_model": "anchor"}, bearing_friction={"model": "palmgren"})
        path = {"gears", "eccentric_bearings"}
    out = {}
    for mode in ("per_family", "merged"):
        m, q, s = _loaded(build, mode, d)
        assert set(m.elements) == path | {"pins", "crank_bearings", "main_bearings", "crank_bearing_friction",
                                          "main_bearing_friction"}
        names, _ = m.observe(q, "pins").per_contact()
        m.set_gap_offsets("pins", {n: 1e-6 for n in names[::3]})
        q_gap = s.solve(0.0, 0.0)
        m.set_gap_offsets("pins", {})
        dm = build(d, contact_element=mode)
        spec = RunSpec(end_time=20 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8)
        dyn = dynamic_te(dm, torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=20 * 2e-5, run_spec=spec)
        c = m.crank_deflections(q)
        out[mode] = (q, q_gap, np.ones(1) if c is None else c, dyn)
    (q0, g0, c0, dyn0), (q1, g1, c1, dyn1) = out["per_family"], out["merged"]
    scale = np.max(np.abs(q0))
    assert np.max(np.abs(q1 - q0)) <= 1e-10 * scale
    assert np.max(np.abs(g1 - q1)) > 1e-6 * scale            # the offsets moved the equilibrium
    assert np.max(np.abs(g1 - g0)) <= 1e-10 * scale
    assert np.max(np.abs(c0)) > 0 and np.allclose(c1, c0, rtol=0, atol=1e-10 * np.max(np.abs(c0)))
    r0, r1 = dyn0["record"], dyn1["record"]
    assert (r1.accepted_steps, r1.newton_iterations, r1.rejected_steps) == (r0.accepted_steps, r0.newton_iterations,
                                                                             r0.rejected_steps)
    assert np.ptp(dyn0["te"]) * ARCSEC > 0.01
    assert np.max(np.abs(dyn1["te"] - dyn0["te"])) * ARCSEC < 1e-9


def test_merged_and_per_family_std_rated_equilibria_agree():
    """The small-tooth-difference reducer (involute ring mesh, output pins, lumped bearings): one
    Exudyn contact object, the same rated equilibrium (tolerance and reason as for the RV) and
    observations."""
    from rvtool.assembly.std_involute import build
    from rvtool.assembly.std_spec import load_design
    d = load_design(designs.path("std_involute"))
    (m, q, _), (m0, q0, _) = _loaded(build, "merged", d), _loaded(build, "per_family", d)
    assert {el.object_number for el in m.elements.values()} == {m.contact_host.object_number}
    assert np.max(np.abs(q - q0)) <= 1e-10 * np.max(np.abs(q0))
    for fam in m.families:
        _same_observation(m.observe(q, fam), m0.observe(q0, fam))


def test_bad_contact_element_names_the_option():
    from rvtool.assembly.rv import build
    from rvtool.errors import RvtoolInputError
    with pytest.raises(RvtoolInputError, match="contact_element.*per_family"):
        build(_rv(), contact_element="fused")


def test_old_import_of_the_layout_choice_still_works():
    from rvtool.assembly import contact_layout
    from rvtool.assembly.cycloid import CONTACT_ELEMENTS, contact_element_mode
    assert contact_element_mode is contact_layout.contact_element_mode
    assert CONTACT_ELEMENTS == ("per_family", "merged")


def test_rv_device_sums_equal_the_host_assembly_bit_for_bit(rv40e):
    """The launchable RV families (pins, involute stage, needle and main-bearing rolling-element
    sets; the tapered pairs are assembled on the host) summed on the device give the bits of the
    host assembly of the same launches summed in family order: the sum order is the same, so any
    difference is an indexing or staging error (as tests/test_merged_element.py for RD-40)."""
    d, (m, q, _), _ = rv40e
    host = m.contact_host
    launchable = {name: el.launchable for name, el in m.elements.items()}
    assert launchable == {"pins": True, "gears": True, "eccentric_bearings": True, "crank_bearings": False,
                          "main_bearings": True}
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(9).normal(0, 1e-3, ql.shape)
    host.invalidate()
    for el in host.members:
        el._key = None      # noqa: every family launches again (test reach-in: no public reset)
    Q, evs = host.evaluate(1.0, ql, vl)
    assert len(host._launched) == 4
    J = host.user_jacobian(1.0, ql, vl, 0.7, 0.3).copy()
    Q_host, J_host = np.zeros_like(Q), np.zeros_like(J)
    for ev in evs:
        Q_host += ev.Q                      # assembled on the host from the same launch buffers
        J_host -= 0.7 * ev.dQdq + 0.3 * ev.dQdv
    assert np.array_equal(Q, Q_host) and np.array_equal(J, J_host)
    # each launched family's fields equal its own fresh host evaluation at the same state
    for el, ev in zip(host.members, evs):
        ref = el.evaluator.evaluate(*el.pose_velocity(ql, vl), check=False)
        assert np.array_equal(ev.Q, ref.Q) and np.array_equal(ev.dQdv, ref.dQdv) and np.array_equal(ev.obs, ref.obs)


@pytest.mark.skipif(not __import__("warp").get_cuda_device_count(), reason="no CUDA device")
def test_merged_rv_host_on_cuda_matches_cpu(rv40e):
    """The same code path on a GPU (staged inputs uploaded, the four launchable families' kernels
    and the device sums on CUDA, the tapered pairs on the host): generalized forces, Jacobian and
    observations equal to the CPU's at the rated state. Tolerance 1e-9 relative, as for the cycloid
    host: the compilers order the kernels' floating-point operations differently (round-off), an
    indexing or staging error is O(1)."""
    from rvtool.assembly.rv import build
    d, (m, q, _), _ = rv40e
    cpu = m.contact_host
    gpu = build(d, contact_element="merged", device="cuda:0").contact_host
    ql = q[cpu.coordinate_indices]
    vl = np.random.default_rng(8).normal(0, 1e-3, ql.shape)
    for host in (cpu, gpu):
        host.invalidate()
    Qc, Qg = cpu.evaluate(5.0, ql, vl)[0], gpu.evaluate(5.0, ql, vl)[0]
    assert len(gpu._launched) == 4
    assert np.allclose(Qg, Qc, rtol=0, atol=1e-9 * np.abs(Qc).max())
    Jc = cpu.user_jacobian(5.0, ql, vl, 0.7, 0.3).copy()
    Jg = gpu.user_jacobian(5.0, ql, vl, 0.7, 0.3)
    assert np.allclose(Jg, Jc, rtol=0, atol=1e-9 * np.abs(Jc).max())
    for a, b in zip(cpu.evaluate(5.0, ql, vl)[1], gpu.evaluate(5.0, ql, vl)[1]):
        assert np.allclose(b.obs, a.obs, rtol=1e-9, atol=1e-12)
