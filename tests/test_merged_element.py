"""One contact element per Exudyn system (issue 19, Deliver 3): exudyn_user_elements.merged_element.

References: central differences of the merged element's generalized forces (the tangent it hands
to Exudyn, rigid and ported housing); the per-family layout (one Exudyn element per family, the
former build) run on the same design and controls, which the merged layout must reproduce to
round-off (same physics, only the summation order of the families changes); A @ B for the
chunked product.
"""
import numpy as np
import pytest

from rvtool import designs

RD40 = designs.path("rd40")
ARCSEC = 180 / np.pi * 3600


def _design(**changes):
    from rvtool.assembly.spec import load_design, replace
    # fewer profile samples keep the builds fast; the comparisons do not depend on them. A main
    # bearing clearance of 2 um keeps the flange's lumped bearing contact off its engagement
    # kink at the rated state (at zero clearance it sits at the kink, where central differences
    # do not converge), as in test_housing_ports
    return replace(load_design(RD40), wheels={"samples_per_tooth": 60}, main_bearing={"radial_clearance": 2e-6},
                   **changes)


def _loaded(mode, d, **kw):
    from rvtool.assembly.cycloid import build
    from rvtool.solver.static import StaticSolver
    m = build(d, contact_element=mode, **kw)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    return m, StaticSolver(m).solve(0.0)


@pytest.fixture(scope="module")
def rd40():
    d = _design()
    return d, _loaded("merged", d), _loaded("per_family", d)


def _fd_tangents(host, q, v, h_of):
    n = len(q)
    K, D = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        h = h_of(j)
        for M, arg in ((K, 0), (D, 1)):
            xp, xm = [q.copy(), v.copy()], [q.copy(), v.copy()]
            xp[arg][j] += h
            xm[arg][j] -= h
            M[:, j] = (host.evaluate(10.0 + j + 0.25 * arg, *xp)[0] - host.evaluate(20.0 + j + 0.25 * arg, *xm)[0]) / (2 * h)
    return K, D


def test_merged_tangent_matches_central_differences(rd40):
    """dQ/dq and dQ/dq_t of all families together (the Jacobian callback's content) vs central
    differences at the loaded state with a random velocity (contact damping active)."""
    d, (m, q), _ = rd40
    host = m.contact_host
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(3).normal(0, 1e-3, ql.shape)
    # steps: 1e-9 m, 1e-8 rad (displacements of ~1e-5 m: the error is truncation ~h^2 and round-off)
    K, D = _fd_tangents(host, ql, vl, lambda j: 1e-8 if j % 3 == 2 else 1e-9)
    J = host.tangent(0.0, ql, vl, 1.0, 0.0)
    Jv = host.tangent(0.0, ql, vl, 0.0, 1.0)
    assert np.linalg.norm(J) > 1e6                       # loaded contacts: stiffness of N/um order
    assert np.linalg.norm(J - K) / np.linalg.norm(K) < 1e-5
    assert np.linalg.norm(Jv - D) / np.linalg.norm(D) < 1e-5
    # the Exudyn callback returns -(f_q dQ/dq + f_v dQ/dq_t) (Exudyn's ObjectGenericODE2 convention)
    cb = host.jacobian_callback(m.mbs, 0.0, host.object_number, ql, vl, 0.7, 0.3)
    assert np.allclose(np.asarray(cb), -(0.7 * J + 0.3 * Jv), rtol=0, atol=1e-12 * np.abs(J).max())


def test_one_exudyn_object_carries_every_family(rd40):
    """The merged build adds one contact object; the families keep their ids, rows and
    per-family observation, equal to the per-family layout's at the same state."""
    d, (m, q), (m_old, q_old) = rd40
    assert set(m.elements) == set(m_old.elements)
    numbers = {el.object_number for el in m.elements.values()}
    assert numbers == {m.contact_host.object_number}
    assert len({el.object_number for el in m_old.elements.values()}) == len(m_old.elements)
    assert m.mbs.systemData.NumberOfObjects() == m_old.mbs.systemData.NumberOfObjects() - len(m.elements) + 1
    assert np.max(np.abs(q - q_old)) <= 1e-12 * np.max(np.abs(q_old))
    for fam in m.families:
        a, b = m.observe(q, fam), m_old.observe(q, fam)
        assert a.ids == b.ids
        assert np.allclose(a.obs, b.obs, rtol=1e-9, atol=1e-9 * max(b.peak, 1.0))


def test_quasi_static_and_dynamic_te_reproduce_the_per_family_layout():
    """Quasi-static TE over 6 points and 40 dynamic steps: the merged layout reproduces the
    per-family figures to round-off (1e-9 arcsec against TE of arcseconds), with the same step
    and Newton counts; the merged run crosses into Python at most 8 times per step."""
    from rvtool.protocols.precision import dynamic_te, quasi_static_te
    from rvtool.solver import RunSpec
    d = _design()
    out = {}
    for mode in ("per_family", "merged"):
        from rvtool.assembly.cycloid import build
        m = build(d, contact_element=mode)
        qs = quasi_static_te(m, torque=d.rated_torque, input_angles=np.arange(6) * m.mesh_period / 5)
        dm = build(d, contact_element=mode)
        spec = RunSpec(end_time=40 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8)
        dyn = dynamic_te(dm, torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=40 * 2e-5, run_spec=spec)
        calls = (dm.contact_host.n_force_calls + dm.contact_host.n_jacobian_calls) if mode == "merged" else \
            sum(e.n_force_calls + e.n_jacobian_calls for e in dm.elements.values())
        out[mode] = (qs, dyn, calls)
    (qs0, dyn0, c0), (qs1, dyn1, c1) = out["per_family"], out["merged"]
    assert np.ptp(qs0["te"]) * ARCSEC > 0.1
    assert np.max(np.abs(qs1["te"] - qs0["te"])) * ARCSEC < 1e-9
    r0, r1 = dyn0["record"], dyn1["record"]
    assert (r1.accepted_steps, r1.newton_iterations, r1.rejected_steps) == (r0.accepted_steps, r0.newton_iterations,
                                                                             r0.rejected_steps)
    assert np.max(np.abs(dyn1["te"] - dyn0["te"])) * ARCSEC < 1e-9
    # element callbacks: 3 families each in the per-family layout, one host in the merged one
    assert c1 * 3 == c0
    # + 2 hooks per attempt (pre-step, post-Newton): no post-step hook, no drive offset function
    assert c1 / r1.accepted_steps + 2 <= 8


def test_load_function_and_fault_injection_in_the_merged_layout():
    """A time-dependent output torque (set once per attempt by the host instead of a load user
    function) gives the per-family layout's trajectory; an injected NaN in a trial evaluation is
    rejected and retried by the driver in both layouts alike (same attempts, same states)."""
    import exudyn as exu

    from rvtool.solver import RunSpec, simulate
    d = _design()
    runs = {}
    for mode, nan in (("per_family", False), ("merged", False), ("per_family", True), ("merged", True)):
        m, q0 = _loaded(mode, d)
        T = -np.sign(m.ratio) * d.rated_torque
        m.set_input_speed(10.0)
        m.set_output_torque_function(lambda t: T * (1 + 2000.0 * t))
        m.mbs.Assemble()
        m.mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
        m.mbs.systemData.SetODE2Coordinates_t(m.body_vector(m.kinematic_state(0.0, 10.0).velocities),
                                              configuration=exu.ConfigurationType.Initial)
        pins = m.family_element("pins")
        # an evaluation of one family at the start state before the run (as the hard cases record
        # it): the host must reuse it, not count a second evaluation, or the injection index shifts
        v0 = m.mbs.systemData.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Initial)
        pins.evaluate(0.0, pins.local(q0), pins.local(v0))
        if nan:
            pins.inject_nan_at = {pins.n_evaluations + 4}
        th = []
        rec = simulate(m.mbs, RunSpec(end_time=20 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8),
                       m.contact_elements(), before_accept=lambda t, q, v: th.append((t, q[m.output_index])))
        runs[mode, nan] = (rec, np.array(th))
        m.set_output_torque_function(None)
        assert m.mbs.GetLoadParameter(m.load, "load") == pytest.approx(T)   # the constant load is back
    for nan in (False, True):
        (r0, th0), (r1, th1) = runs["per_family", nan], runs["merged", nan]
        assert (r1.accepted_steps, r1.rejected_steps, r1.reject_reasons) == (r0.accepted_steps, r0.rejected_steps,
                                                                             r0.reject_reasons)
        assert np.array_equal(th1[:, 0], th0[:, 0])
        # output angle ~1e-3 rad: agreement to round-off of the family summation order
        assert np.max(np.abs(th1[:, 1] - th0[:, 1])) < 1e-13
    assert runs["merged", True][0].reject_reasons == {"non-finite contact force in a trial evaluation": 1}
    assert runs["merged", False][0].rejected_steps == 0


def test_small_matmul_equals_the_product():
    from exudyn_user_elements.merged_element import small_matmul
    rng = np.random.default_rng(0)
    for m_, k, n in ((80, 120, 80), (12, 7, 80), (200, 200, 30)):
        A, B = rng.normal(size=(m_, k)), rng.normal(size=(k, n))
        # chunked inner sums: the same products, summed in another order (round-off only)
        assert np.allclose(small_matmul(A, B), A @ B, rtol=0, atol=1e-12 * np.abs(A @ B).max())


def test_bad_contact_element_names_the_option():
    from rvtool.assembly.cycloid import build
    from rvtool.errors import RvtoolInputError
    with pytest.raises(RvtoolInputError, match="contact_element.*per_family"):
        build(_design(), contact_element="fused")


def test_ported_housing_merged_tangent_and_equilibrium():
    """Elastic housing through ports: the merged element spans bodies and eta, contracts on the pins
    in contact and hands Exudyn sparse triplets. Its tangent vs central differences, its sparse
    Jacobian vs the dense one, and the rated equilibrium vs the per-family layout (dense
    92-coordinate pin element)."""
    import exudyn as exu
    # a coarser housing mesh than the default keeps the reduction at ~2 s (as test_housing_ports)
    d = _design(housing={"model": "ports", "structure": {"mesh_size": 0.006}})
    m, q = _loaded("merged", d)
    m_old, q_old = _loaded("per_family", d)
    host = m.contact_host
    assert host.sparse and host.n == 3 * (d.n_wheels + 2) + m.housing.n
    assert np.max(np.abs(q - q_old)) <= 1e-9 * np.max(np.abs(q_old))
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(1).normal(0, 1e-4, ql.shape)
    nr = host.n_rigid
    K, _ = _fd_tangents(host, ql, vl, lambda j: 1e-8 if (j < nr and j % 3 == 2) else 1e-9)
    J = host.tangent(0.0, ql, vl, 1.0, 0.0)
    assert np.linalg.norm(J[nr:, nr:]) > 1e-3 * np.linalg.norm(J)     # the housing block is loaded
    assert np.linalg.norm(J - K) / np.linalg.norm(K) < 1e-5
    mc = host.jacobian_callback(m.mbs, 0.0, host.object_number, ql, vl, 1.0, 0.0)
    assert isinstance(mc, exu.MatrixContainer)
    assert np.array_equal(np.asarray(mc.Convert2DenseMatrix()), -J)


def test_drive_follows_time_when_the_driver_gets_no_elements():
    """The host is registered with the system, so a run given no contact elements still moves the
    input as prescribed (the offset is set per attempt, not by a Python offset function)."""
    import exudyn as exu

    from rvtool.solver import RunSpec, simulate
    m, q0 = _loaded("merged", _design())
    m.set_input_speed(10.0)
    m.mbs.Assemble()
    m.mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    m.mbs.systemData.SetODE2Coordinates_t(m.body_vector(m.kinematic_state(0.0, 10.0).velocities),
                                          configuration=exu.ConfigurationType.Initial)
    rec = simulate(m.mbs, RunSpec(end_time=10 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8), [])
    q = m.mbs.systemData.GetODE2Coordinates()
    assert rec.accepted_steps == 10
    assert q[m.input_index] == pytest.approx(10.0 * 10 * 2e-5, rel=1e-12)


def test_gap_offsets_and_commits_reach_the_merged_sum(rd40):
    """Changing a family's gap offsets (or committing its history) drops the host's cached sum:
    the next evaluation at the same state sees the change, as the per-family element does."""
    d, (m, q), _ = rd40
    host = m.contact_host
    ql = q[host.coordinate_indices]
    v = np.zeros_like(ql)
    Q0 = host.evaluate(0.0, ql, v)[0].copy()
    names, _ = m.observe(q, "pins").per_contact()
    m.set_gap_offsets("pins", {n: 2e-6 for n in names})
    Q1 = host.evaluate(0.0, ql, v)[0].copy()
    assert np.linalg.norm(Q1 - Q0) > 1e-3 * np.linalg.norm(Q0)      # 2 um opened gaps unload the pins
    m.set_gap_offsets("pins", {})
    assert np.array_equal(host.evaluate(0.0, ql, v)[0], Q0)          # zeros restore the built element
    pins = m.family_element("pins")
    n0 = pins.n_evaluations
    host.evaluate(0.0, ql, v)
    assert pins.n_evaluations == n0                                   # cached
    m.commit_contacts(q)
    host.evaluate(0.0, ql, v)
    assert pins.n_evaluations == n0 + 1                               # re-evaluated after the commit


def test_device_sums_equal_the_host_assembly_bit_for_bit(rd40):
    """The launchable families' rows summed on the device (warp_contacts.segment_sum) give the bits
    of the host assembly of the same launches (each family's CSR-assembled evaluation, summed in
    family order): the sum order is the same, so any difference is an indexing error."""
    d, (m, q), _ = rd40
    host = m.contact_host
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(5).normal(0, 1e-3, ql.shape)
    host.invalidate()
    for el in host.members:
        el._key = None      # noqa: every family launches again (test reach-in: no public reset)
    Q, evs = host.evaluate(1.0, ql, vl)
    assert host.row_sums() is not None and len(host._launched) == len(host.members)
    J = host.user_jacobian(1.0, ql, vl, 0.7, 0.3).copy()
    Q_host = np.zeros_like(Q)
    J_host = np.zeros_like(J)
    for el, ev in zip(host.members, evs):
        Q_host += ev.Q                      # assembled on the host from the same launch buffers
        J_host -= 0.7 * ev.dQdq + 0.3 * ev.dQdv
    assert np.array_equal(Q, Q_host) and np.array_equal(J, J_host)
    # the same state again after the host's cache is dropped: every family is served from its own
    # cache and summed on the host, with the same bits
    host.invalidate()
    Q2, _ = host.evaluate(1.0, ql, vl)
    assert len(host._launched) == 0
    assert np.array_equal(Q2, Q) and np.array_equal(host.user_jacobian(1.0, ql, vl, 0.7, 0.3), J)


def test_launched_evaluation_read_after_a_relaunch_is_unchanged(rd40):
    """A launched evaluation assembles its fields from the kernel's buffers when read; read after
    its family launched again (the buffers overwritten), it evaluates afresh at its own state and
    gives the same values."""
    d, (m, q), _ = rd40
    host = m.contact_host
    ql = q[host.coordinate_indices]
    vl = np.random.default_rng(6).normal(0, 1e-3, ql.shape)
    _, evs = host.evaluate(2.0, ql, vl)
    first = {f: [getattr(ev, f) for ev in evs] for f in ("Q", "obs")}
    _, evs_same = host.evaluate(3.0, ql, vl)            # identical state, other time: launches again
    _, evs2 = host.evaluate(4.0, ql + 1e-7, vl)          # another state: the buffers now hold it
    for k, ev in enumerate(evs_same):
        assert np.array_equal(ev.Q, first["Q"][k]) and np.array_equal(ev.obs, first["obs"][k])
        assert np.array_equal(ev.dQdq, evs[k].dQdq)      # evs[k]: read after two relaunches
    assert not np.array_equal(evs2[0].obs, first["obs"][0])


@pytest.mark.skipif(not __import__("warp").get_cuda_device_count(), reason="no CUDA device")
def test_merged_host_on_cuda_matches_cpu(rd40):
    """The same code path on a GPU (family kernels, device sums and Jacobian as CUDA graphs):
    generalized forces and Jacobian equal to the CPU's at the loaded state. Tolerance 1e-9
    relative: the two compilers contract and order the kernels' floating-point operations
    differently (round-off ~1e-15 per operation, amplified by the contact laws' stiffness to far
    below 1e-9), while an indexing or staging error is O(1)."""
    from rvtool.assembly.cycloid import build
    d, (m, q), _ = rd40
    cpu = m.contact_host
    gpu_model = build(d, contact_element="merged", device="cuda:0")
    gpu = gpu_model.contact_host
    ql = q[cpu.coordinate_indices]
    vl = np.random.default_rng(8).normal(0, 1e-3, ql.shape)
    for host in (cpu, gpu):
        host.invalidate()
    Qc, Qg = cpu.evaluate(5.0, ql, vl)[0], gpu.evaluate(5.0, ql, vl)[0]
    assert len(gpu._launched) == len(gpu.members)
    assert np.allclose(Qg, Qc, rtol=0, atol=1e-9 * np.abs(Qc).max())
    Jc = cpu.user_jacobian(5.0, ql, vl, 0.7, 0.3).copy()
    Jg = gpu.user_jacobian(5.0, ql, vl, 0.7, 0.3)
    assert np.allclose(Jg, Jc, rtol=0, atol=1e-9 * np.abs(Jc).max())
    obs_c = [ev.obs for ev in cpu.evaluate(5.0, ql, vl)[1]]
    obs_g = [ev.obs for ev in gpu.evaluate(5.0, ql, vl)[1]]
    for a, b in zip(obs_c, obs_g):
        assert np.allclose(a, b, rtol=1e-9, atol=1e-12)


def test_elastic_pin_closure_is_summed_on_the_host():
    """A family whose evaluator only forwards to an inner set (the elastic ring-pin closure, Eq.
    (series_contact)) is not launched by the host (the inner set's launch would evaluate the
    station bodies, not the element's): it is assembled on the host next to the device-summed
    bearings and output pins, and the loaded equilibrium equals the per-family layout's."""
    d = _design(pins={"support": {"model": "simply_supported", "ends": [-0.015, 0.015]}})
    (m, q), (m_old, q_old) = _loaded("merged", d), _loaded("per_family", d)
    launchable = {name: el.launchable for name, el in m.elements.items()}
    assert launchable["pins"] is False and launchable["bearings"] and launchable["output_pins"]
    # static equilibria converged to the Newton tolerance from the same start: equal far below it
    assert np.allclose(q, q_old, rtol=0, atol=1e-12)
