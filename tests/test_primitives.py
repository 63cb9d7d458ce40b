"""Contact primitives (warp_contacts.primitives): batched Warp kernels vs the
NumPy double-precision references in both precisions, circle gap sign and
force direction, damping ramp and tensile clipping, friction dissipativity,
analytic derivatives vs central differences, and input errors.

Following the paper (Section "Contact laws, signed clearance, and force
direction"), the reference evaluates the precision-rounded inputs promoted to
float64, so a comparison measures arithmetic error only.
"""
import numpy as np
import pytest
import warp as wp

from rvtool.errors import RvtoolInputError
from warp_contacts import circle_geometry_ref, laws_ref
from warp_contacts.precision import resolve_device
from warp_contacts.primitives import eval_circle_contact, eval_friction, eval_normal_force, eval_power_law

resolve_device("cpu")  # initializes Warp
DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    wp.get_cuda_device_count() == 0, reason="no CUDA device"))]
PRECISIONS = ["float64", "float32"]
EPS32 = float(np.finfo(np.float32).eps)
# float64: the kernels and NumPy evaluate the same formulas; libm pow/exp/tanh
# differ by at most a few ulp (eps64 * |p ln delta| ~ 1e-14), while a formula or
# branch error would be O(1), so 1e-12 relative is a safe, still sharp bound.
RTOL64 = 1e-12


def _rounded(x, precision):
    """Inputs as the kernel sees them (rounded to ``precision``), promoted to float64."""
    return np.asarray(x, dtype=precision).astype(np.float64)


def _law_inputs(rng, n=2000):
    """Coefficients over the practical range, the paper's exponents 1, 10/9, 3/2 and
    some arbitrary p in [1, 2.5]; approaches of both signs from 1 nm to 0.1 mm and exact zeros."""
    k = 10.0 ** rng.uniform(6.0, 11.0, n)
    p = rng.choice([1.0, 10.0 / 9.0, 1.5], n)
    p[::4] = rng.uniform(1.0, 2.5, p[::4].size)
    delta = 10.0 ** rng.uniform(-9.0, -4.0, n) * rng.choice([-1.0, 1.0], n)
    delta[::50] = 0.0
    return k, p, delta


def _pow_rtol(precision, p, delta):
    """Relative error bound of k delta^p (and p F / delta) evaluated in ``precision``.

    float32: pow is exp(p ln delta) inside the math library; a rounding of the
    intermediate y = p ln delta by eps |y| is amplified to a relative error
    eps |y| of the result, so the bound is eps32 (8 + p |ln delta|): a few ulp
    for pow (CUDA's powf is specified to 4 ulp), the product with k and the
    division in the derivative, plus that conditioning term (|y| <= 60 here).
    """
    if precision == "float64":
        return RTOL64
    return EPS32 * (8.0 + p * np.abs(np.log(np.where(delta > 0.0, delta, 1.0))))


def _circle_sweep(internal, n_angles=32, n_approach=201, seed=0):
    """Pin-like circles (r_A = 3 mm) outside / inside a 50 mm circle B whose centre
    is off the origin; signed approach -g from -50 um to +50 um, many centre directions."""
    rng = np.random.default_rng(seed)
    ra, rb = 3e-3, 50e-3
    cb = np.array([0.012, -0.007])
    theta = np.repeat(np.linspace(0.0, 2 * np.pi, n_angles, endpoint=False) + rng.uniform(0, 0.1), n_approach)
    s = np.tile(np.linspace(-50e-6, 50e-6, n_approach), n_angles)  # signed approach -g
    dist = (rb - ra + s) if internal else (ra + rb - s)
    u = np.column_stack([np.cos(theta), np.sin(theta)])  # direction A -> B
    ca = cb - dist[:, None] * u
    return ca, np.broadcast_to(cb, ca.shape).copy(), ra, rb


def _circle_reference(ca, cb, ra, rb, internal, k, p, precision):
    r = [_rounded(x, precision) for x in (ca, cb, ra, rb, k, p)]
    g, n, L = circle_geometry_ref.circle_gap(r[0], r[1], r[2], r[3], internal)
    fn, _ = laws_ref.power_law(r[4], r[5], -g)
    return g, circle_geometry_ref.circle_force_on_a(fn, n, internal), L, r


# ---------------------------------------------------------------- kernels vs references

@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
def test_power_law_matches_reference(device, precision):
    k, p, delta = _law_inputs(np.random.default_rng(1))
    F, dF = eval_power_law(k, p, delta, precision=precision, device=device)
    assert F.dtype == np.dtype(precision) and dF.dtype == np.dtype(precision)
    kr, pr, dr = (_rounded(x, precision) for x in (k, p, delta))
    Fr, dFr = laws_ref.power_law(kr, pr, dr)
    rtol = _pow_rtol(precision, pr, dr)
    assert np.all(np.abs(F - Fr) <= rtol * Fr)
    assert np.all(np.abs(dF - dFr) <= rtol * dFr)
    assert np.all(F[dr <= 0.0] == 0.0) and np.all(dF[dr <= 0.0] == 0.0)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
def test_normal_force_matches_reference(device, precision):
    rng = np.random.default_rng(2)
    k, p, delta = _law_inputs(rng)
    n = delta.size
    c = 10.0 ** rng.uniform(2.0, 6.0, n)
    c[::7] = 0.0
    delta_r = 10.0 ** rng.uniform(-8.0, -5.0, n)
    # rates of both signs large enough that many samples are clipped (tensile damping)
    delta_dot = rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-4.0, 1.0, n)
    out = eval_normal_force(k, p, c, delta_r, delta, delta_dot, precision=precision, device=device)
    kr, pr, cr, drr, dr, ddr = (_rounded(x, precision) for x in (k, p, c, delta_r, delta, delta_dot))
    ref = laws_ref.normal_force(kr, pr, cr, drr, dr, ddr)
    fe, dfe = laws_ref.power_law(kr, pr, dr)
    r, dramp = laws_ref.damping_ramp(dr, drr)
    # F = F_el + c r delta_dot may cancel near the clipping boundary, so the bound is
    # relative to the magnitudes of the two terms (each a few roundings), not to F
    rtol = _pow_rtol(precision, pr, dr)
    rtol_d = RTOL64 if precision == "float64" else 8.0 * EPS32
    tol_f = rtol * fe + rtol_d * np.abs(cr * r * ddr)
    assert np.all(np.abs(out[0] - ref[0]) <= tol_f)
    # partials are compared where both evaluations are surely on the same side of the clip
    same = (ref[0] == 0.0) & (out[0] == 0.0) | (ref[0] > tol_f)
    assert np.mean(same) > 0.9
    tol_d = rtol * dfe + rtol_d * np.abs(cr * dramp * ddr)
    assert np.all(np.abs(out[1] - ref[1])[same] <= tol_d[same])
    assert np.all(np.abs(out[2] - ref[2])[same] <= (rtol_d * cr * r)[same])
    assert np.any((ref[0] == 0.0) & (dr > 0.0)) and np.any(ref[0] > 0.0)  # both clipped and loaded samples


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
def test_friction_matches_reference(device, precision):
    rng = np.random.default_rng(3)
    n = 2000
    mu_k = rng.uniform(0.0, 0.3, n)
    mu_s = mu_k * rng.uniform(0.5, 2.0, n)
    v_s = 10.0 ** rng.uniform(-4.0, -1.0, n)
    v_reg = 10.0 ** rng.uniform(-6.0, -3.0, n)
    v = rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-7.0, 0.0, n)
    mu, dmu = eval_friction(mu_k, mu_s, v_s, v_reg, v, precision=precision, device=device)
    mkr, msr, vsr, vrr, vr = (_rounded(x, precision) for x in (mu_k, mu_s, v_s, v_reg, v))
    mur, dmur = laws_ref.friction_coefficient(mkr, msr, vsr, vrr, vr)
    mu_max = np.maximum(mkr, msr)
    if precision == "float64":
        tol, tol_d = RTOL64 * mu_max, RTOL64 * (mu_max / vrr + np.abs(msr - mkr) / vsr)
    else:
        # absolute bounds: exp(-x^2) carries a relative error ~ (3 x^2 + 2) eps but
        # exp(-x^2)(3 x^2 + 4) <= 4, tanh is absolute-accurate to ~2 eps; summed over
        # the few operations this stays below 10 eps max(mu); the derivative adds the
        # cancellation in 1 - tanh^2 (~6 eps / v_reg) and the Stribeck slope (<= ~4 eps/v_s)
        tol = 16.0 * EPS32 * mu_max
        tol_d = 16.0 * EPS32 * (mu_max / vrr + np.abs(msr - mkr) / vsr)
    assert np.all(np.abs(mu - mur) <= tol)
    assert np.all(np.abs(dmu - dmur) <= tol_d)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("internal", [False, True])
def test_circle_contact_matches_reference(device, precision, internal):
    ca, cb, ra, rb = _circle_sweep(internal)
    k, p = 1e10, 1.5
    flags = np.full(len(ca), internal)
    g, f = eval_circle_contact(ca, cb, ra, rb, flags, k, p, precision=precision, device=device)
    gr, fr, L, (_, _, rar, rbr, kr, pr) = _circle_reference(ca, cb, ra, rb, flags, k, p, precision)
    eps = float(np.finfo(precision).eps)
    # gap = L - r_A - r_B (or R_B - r_A - L): rounding of c_B - c_A, of the length and of two
    # subtractions, each <= eps times a length of at most L + r_A + r_B: 8 eps (L + r_A + r_B)
    gap_tol = 8.0 * eps * (L + rar + rbr)
    assert np.all(np.abs(g - gr) <= gap_tol)
    # force: the gap error moves the indentation by at most gap_tol, so |dF_n| is bounded by
    # the law's increase over [delta - gap_tol, delta + gap_tol]; plus the pow arithmetic
    # and a few eps for the unit direction
    delta = -gr
    lip = laws_ref.power_law(kr, pr, delta + gap_tol)[0] - laws_ref.power_law(kr, pr, delta - gap_tol)[0]
    fn_ref = np.linalg.norm(fr, axis=1)
    tol_f = lip + (_pow_rtol(precision, pr, delta) + 4.0 * eps) * fn_ref
    assert np.all(np.linalg.norm(f - fr, axis=1) <= tol_f)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("internal", [False, True])
def test_circle_force_direction_and_sign(device, precision, internal):
    """External: force on A points away from B; internal: toward B's centre.
    Separated configurations (reference gap above 1e-7 m, clear of the rounding-scale
    contact boundary) carry exactly zero force."""
    ca, cb, ra, rb = _circle_sweep(internal, seed=4)
    g, f = eval_circle_contact(ca, cb, ra, rb, internal, 1e10, 1.5, precision=precision, device=device)
    gr, _, _, (car, cbr, *_) = _circle_reference(ca, cb, ra, rb, internal, 1e10, 1.5, precision)
    expected = (cbr - car) if internal else (car - cbr)
    expected /= np.linalg.norm(expected, axis=1)[:, None]
    compressed, separated = gr < -1e-7, gr > 1e-7
    assert compressed.sum() > 0.4 * g.size and separated.sum() > 0.4 * g.size
    assert np.all(np.sign(g[compressed | separated]) == np.sign(gr[compressed | separated]))
    fn = np.linalg.norm(f, axis=1)
    assert np.all(fn[compressed] > 0.0)
    cosine = np.einsum("ij,ij->i", f[compressed], expected[compressed]) / fn[compressed]
    assert np.all(cosine > 1.0 - 16.0 * float(np.finfo(precision).eps))
    assert np.all(f[separated] == 0.0)


# ---------------------------------------------------------------- laws: ramp, clipping, dissipativity

@pytest.mark.parametrize("device", DEVICES)
def test_damping_ramp_and_tensile_clipping(device):
    """Eq. (normal_force): F_n = max(0, k delta^p + c min(delta/delta_r, 1) delta_dot)."""
    k, p, c, dr = 1e10, 1.5, 2e4, 1e-6
    delta = np.array([-1e-6, 0.0, 0.25e-6, 0.5e-6, 1e-6, 4e-6, 4e-6, 0.5e-6, 0.5e-6])
    ddot = np.array([-1.0, 1.0, 1e-2, -1e-2, 1e-2, 1e-2, -1.0, -10.0, -1e-3])
    F, dF, dFv = eval_normal_force(k, p, c, dr, delta, ddot, device=device)
    fe = k * np.maximum(delta, 0.0) ** p
    ramp = np.clip(delta / dr, 0.0, 1.0)
    expected = np.maximum(0.0, fe + c * ramp * ddot)
    expected[delta <= 0.0] = 0.0  # open contact: no force whatever the rate
    assert np.allclose(F, expected, rtol=1e-14, atol=0.0)
    assert F[0] == 0.0 and F[1] == 0.0
    # inside the ramp (delta < delta_r) the damping term scales with delta / delta_r
    assert F[2] == pytest.approx(fe[2] + c * 0.25 * 1e-2, rel=1e-14)
    assert dF[2] == pytest.approx(p * fe[2] / delta[2] + c / dr * 1e-2, rel=1e-14)
    assert dFv[2] == pytest.approx(c * 0.25, rel=1e-14)
    # beyond the ramp full damping and no ramp derivative
    assert dF[5] == pytest.approx(p * fe[5] / delta[5], rel=1e-14) and dFv[5] == pytest.approx(c, rel=1e-14)
    # tensile damping (pulling the surfaces together) is clipped: zero force and zero tangent
    for i in (6, 7):
        assert fe[i] + c * ramp[i] * ddot[i] < 0.0
        assert F[i] == 0.0 and dF[i] == 0.0 and dFv[i] == 0.0
    # the ramp makes the force continuous at engagement for any rate: it vanishes linearly
    # in delta instead of jumping to c delta_dot (= 2e5 N here) at first touch
    ds = np.array([1e-15, 1e-13])
    Fs, _, _ = eval_normal_force(k, p, c, dr, ds, np.array([10.0, 10.0]), device=device)
    assert np.allclose(Fs, k * ds ** p + c * 10.0 * ds / dr, rtol=1e-14, atol=0.0)
    assert Fs[0] < 1e-8 * c * 10.0


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision", PRECISIONS)
def test_friction_is_dissipative(device, precision):
    """Eq. (friction): mu_reg(v) v >= 0, mu_reg odd in v, for mu_s above and below mu_k."""
    v = np.concatenate([np.geomspace(1e-9, 10.0, 500), [0.0]])
    v = np.concatenate([v, -v])
    for mu_k, mu_s in ((0.1, 0.3), (0.3, 0.1), (0.0, 0.2), (0.2, 0.0)):
        mu, _ = eval_friction(mu_k, mu_s, 1e-2, 1e-4, v, precision=precision, device=device)
        assert np.all(mu * v >= 0.0)
        assert np.all(mu[:501] == -mu[501:])
        assert mu[500] == 0.0


# ---------------------------------------------------------------- analytic derivatives

def _central(fun, x, h):
    return (fun(x + h) - fun(x - h)) / (2.0 * h)


def test_derivatives_match_central_differences():
    """Central differences with h = 1e-6 x: truncation ~ (h/x)^2 ~ 1e-12, round-off
    ~ eps64 F / (h dF) ~ 2e-10 relative; 1e-7 leaves margin. Samples avoid the kinks
    (delta = 0, delta = delta_r, the clipping boundary)."""
    rng = np.random.default_rng(6)
    n = 200
    k = 10.0 ** rng.uniform(6.0, 11.0, n)
    p = rng.uniform(1.0, 2.5, n)
    delta = 10.0 ** rng.uniform(-7.0, -4.0, n)
    h = 1e-6 * delta
    F, dF = eval_power_law(k, p, delta)
    assert np.allclose(dF, _central(lambda d: eval_power_law(k, p, d)[0], delta, h), rtol=1e-7, atol=0.0)

    c = 10.0 ** rng.uniform(2.0, 5.0, n)
    delta_r = delta * np.where(rng.random(n) < 0.5, rng.uniform(1.2, 5.0, n), rng.uniform(0.2, 0.8, n))
    ddot = rng.uniform(0.0, 1e-2, n)  # compressive: F_n stays well away from the clip
    F, dFd, dFv = eval_normal_force(k, p, c, delta_r, delta, ddot)
    assert np.all(F > 0.0)
    fd = _central(lambda d: eval_normal_force(k, p, c, delta_r, d, ddot)[0], delta, h)
    # where the damping term dominates F but not dF/d delta (delta > delta_r), the round-off
    # of the difference, ~ eps64 F / h, sets the floor
    assert np.all(np.abs(dFd - fd) <= 1e-7 * np.abs(dFd) + 4.0 * np.finfo(float).eps * F / h)
    hv = 1e-6 * np.maximum(ddot, 1e-6)
    fv = _central(lambda v: eval_normal_force(k, p, c, delta_r, delta, v)[0], ddot, hv)
    assert np.allclose(dFv, fv, rtol=1e-7, atol=1e-7 * np.max(np.abs(dFv)))

    mu_k, mu_s, v_s, v_reg = 0.1, 0.25, 1e-2, 1e-4
    v = rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-6.0, -1.0, n)
    mu, dmu = eval_friction(mu_k, mu_s, v_s, v_reg, v)
    hv = 1e-6 * np.maximum(np.abs(v), v_reg)
    fd = _central(lambda x: eval_friction(mu_k, mu_s, v_s, v_reg, x)[0], v, hv)
    # scale of d mu / dv: mu_s / v_reg (the tanh slope at v = 0)
    assert np.allclose(dmu, fd, rtol=1e-7, atol=1e-7 * mu_s / v_reg)


# ---------------------------------------------------------------- broadcasting and input errors

def test_scalars_broadcast_and_empty_batch():
    F, _ = eval_power_law(1e10, 1.5, np.array([1e-6, 2e-6]))
    F1, _ = eval_power_law(np.array([1e10, 1e10]), np.array([1.5, 1.5]), np.array([1e-6, 2e-6]))
    assert np.array_equal(F, F1)
    g, f = eval_circle_contact([0.0, 0.0], np.array([[0.053, 0.0], [0.0, 0.0529]]), 0.003, 0.05, False, 1e10, 1.5)
    assert g.shape == (2,) and f.shape == (2, 2) and f[0, 0] < 0.0 and f[1, 1] < 0.0
    F, dF = eval_power_law(1e10, 1.5, np.zeros(0))
    assert F.shape == (0,) and dF.shape == (0,)


CIRCLE = dict(ca=np.zeros((3, 2)), cb=np.full((3, 2), 0.03), ra=0.003, rb=0.05, internal=True, k=1e10, p=1.5)
NORMAL = dict(k=1e10, p=1.5, c=1e3, delta_r=1e-6, delta=np.zeros(3), delta_dot=np.zeros(3))
FRICTION = dict(mu_k=0.1, mu_s=0.2, v_s=1e-2, v_reg=1e-4, v=np.zeros(3))
POWER = dict(k=1e10, p=1.5, delta=np.zeros(3))
BAD_INPUTS = [
    (eval_power_law, POWER, {"k": -1.0}, "k"),
    (eval_power_law, POWER, {"k": np.array([1e10, -5.0, 1e10])}, "k"),
    (eval_power_law, POWER, {"p": 0.5}, "p"),
    (eval_power_law, POWER, {"delta": np.array([0.0, np.nan, 0.0])}, "delta"),
    (eval_power_law, POWER, {"k": np.inf}, "k"),
    (eval_power_law, POWER, {"k": np.full(5, 1e10)}, "delta"),  # lengths 5 vs 3
    (eval_power_law, POWER, {"delta": np.zeros((3, 2))}, "delta"),
    (eval_power_law, POWER, {"delta": "abc"}, "delta"),
    (eval_power_law, POWER, {"precision": "float16"}, "precision"),
    (eval_power_law, POWER, {"device": "tpu"}, "device"),
    (eval_power_law, POWER, {"k": 1e40, "precision": "float32"}, "k"),  # overflows float32
    (eval_normal_force, NORMAL, {"c": -1.0}, "c"),
    (eval_normal_force, NORMAL, {"delta_r": 0.0}, "delta_r"),
    (eval_normal_force, NORMAL, {"delta_r": 1e-50, "precision": "float32"}, "delta_r"),  # underflows to 0
    (eval_normal_force, NORMAL, {"delta_dot": np.array([0.0, np.inf, 0.0])}, "delta_dot"),
    (eval_normal_force, NORMAL, {"p": 0.9}, "p"),
    (eval_friction, FRICTION, {"mu_k": -0.1}, "mu_k"),
    (eval_friction, FRICTION, {"mu_s": -0.1}, "mu_s"),
    (eval_friction, FRICTION, {"v_s": 0.0}, "v_s"),
    (eval_friction, FRICTION, {"v_reg": -1e-4}, "v_reg"),
    (eval_friction, FRICTION, {"mu_k": np.full(3, 0.1), "v": np.zeros(4)}, "v"),
    (eval_circle_contact, CIRCLE, {"ra": 0.0}, "ra"),
    (eval_circle_contact, CIRCLE, {"rb": -0.05}, "rb"),
    (eval_circle_contact, CIRCLE, {"ra": 0.06}, "rb"),  # internal contact needs rb > ra
    (eval_circle_contact, CIRCLE, {"ca": np.zeros((3, 3))}, "ca"),
    (eval_circle_contact, CIRCLE, {"cb": np.full((4, 2), 0.03)}, "cb"),
    (eval_circle_contact, CIRCLE, {"ca": np.array([[0.0, np.nan]] * 3)}, "ca"),
    (eval_circle_contact, CIRCLE, {"internal": np.array([0, 2, 1])}, "internal"),
    (eval_circle_contact, CIRCLE, {"k": -1e10}, "k"),
    (eval_circle_contact, CIRCLE, {"p": 0.0}, "p"),
]


@pytest.mark.parametrize("fun,base,change,name", BAD_INPUTS,
                         ids=[f"{f.__name__}-{n}-{i}" for i, (f, _, _, n) in enumerate(BAD_INPUTS)])
def test_bad_inputs_raise_naming_the_parameter(fun, base, change, name):
    with pytest.raises(RvtoolInputError, match=rf"\b{name}\b"):
        fun(**{**base, **change})
