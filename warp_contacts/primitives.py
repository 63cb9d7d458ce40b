"""Batched Warp evaluation of the scalar contact laws and of circle contact.

One kernel launch evaluates N independent inputs. The kernels are thin: the
physics lives in the Warp functions of :mod:`warp_contacts.laws` (Eq.
(normal_force), Eq. (friction)) and :mod:`warp_contacts.circle_geometry`
(signed gap and force direction); the NumPy references are
:mod:`warp_contacts.laws_ref` and :mod:`warp_contacts.circle_geometry_ref`.

The public functions take NumPy arrays (1-D of one common length N; a scalar
is broadcast to N) and return NumPy arrays of the selected precision.
``precision="float64"`` is the default, ``"float32"`` an explicit option;
``device`` is any Warp device ("cpu", "cuda", "cuda:N").

Units: lengths in m, velocities in m/s, forces in N; a coefficient k that
multiplies delta^p has units N m^-p, a damping coefficient c N s/m.
"""
import functools
import math

import numpy as np
import warp as wp

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_finite, check_range

from .circle_geometry import circle_funcs
from .laws import law_funcs
from .precision import resolve_device, scalar_types


@functools.lru_cache(maxsize=None)
def _kernels(dtype):
    """The primitive kernels for Warp scalar type ``dtype`` (compiled once per type)."""
    L = law_funcs(dtype)
    C = circle_funcs(dtype)
    vec2 = C.vec2
    power_law = L.power_law
    normal_force = L.normal_force
    friction_coefficient = L.friction_coefficient
    circle_gap = C.circle_gap
    circle_force_on_a = C.circle_force_on_a

    @wp.kernel(module="unique")
    def power_law_kernel(
        # Model:
        k_in: wp.array(dtype=dtype),
        p_in: wp.array(dtype=dtype),
        # Data in:
        delta_in: wp.array(dtype=dtype),
        # Data out:
        f_out: wp.array(dtype=dtype),
        df_out: wp.array(dtype=dtype),
    ):
        i = wp.tid()
        f, df = power_law(k_in[i], p_in[i], delta_in[i])
        f_out[i] = f
        df_out[i] = df

    @wp.kernel(module="unique")
    def normal_force_kernel(
        # Model:
        k_in: wp.array(dtype=dtype),
        p_in: wp.array(dtype=dtype),
        c_in: wp.array(dtype=dtype),
        delta_r_in: wp.array(dtype=dtype),
        # Data in:
        delta_in: wp.array(dtype=dtype),
        delta_dot_in: wp.array(dtype=dtype),
        # Data out:
        f_out: wp.array(dtype=dtype),
        df_ddelta_out: wp.array(dtype=dtype),
        df_ddelta_dot_out: wp.array(dtype=dtype),
    ):
        i = wp.tid()
        f, fd, fdd = normal_force(k_in[i], p_in[i], c_in[i], delta_r_in[i], delta_in[i], delta_dot_in[i])
        f_out[i] = f
        df_ddelta_out[i] = fd
        df_ddelta_dot_out[i] = fdd

    @wp.kernel(module="unique")
    def friction_kernel(
        # Model:
        mu_k_in: wp.array(dtype=dtype),
        mu_s_in: wp.array(dtype=dtype),
        v_s_in: wp.array(dtype=dtype),
        v_reg_in: wp.array(dtype=dtype),
        # Data in:
        v_in: wp.array(dtype=dtype),
        # Data out:
        mu_out: wp.array(dtype=dtype),
        dmu_out: wp.array(dtype=dtype),
    ):
        i = wp.tid()
        mu, dmu = friction_coefficient(mu_k_in[i], mu_s_in[i], v_s_in[i], v_reg_in[i], v_in[i])
        mu_out[i] = mu
        dmu_out[i] = dmu

    @wp.kernel(module="unique")
    def circle_contact_kernel(
        # Model:
        ra_in: wp.array(dtype=dtype),
        rb_in: wp.array(dtype=dtype),
        internal_in: wp.array(dtype=wp.int32),
        k_in: wp.array(dtype=dtype),
        p_in: wp.array(dtype=dtype),
        # Data in:
        ca_in: wp.array(dtype=vec2),
        cb_in: wp.array(dtype=vec2),
        # Data out:
        gap_out: wp.array(dtype=dtype),
        force_a_out: wp.array(dtype=vec2),
    ):
        i = wp.tid()
        internal = internal_in[i]
        g, n, dist = circle_gap(ca_in[i], cb_in[i], ra_in[i], rb_in[i], internal)
        fn, dfn = power_law(k_in[i], p_in[i], -g)
        gap_out[i] = g
        force_a_out[i] = circle_force_on_a(fn, n, internal)

    return {"power_law": power_law_kernel, "normal_force": normal_force_kernel,
            "friction": friction_kernel, "circle_contact": circle_contact_kernel, "vec2": vec2}


# ---------------------------------------------------------------- input checks

def _real_array(name, value):
    """``value`` as a float64 array, or an error naming ``name``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise RvtoolInputError(f"{name} must be a real number or an array of real numbers; got {value!r}") from None
    return check_finite(name, arr)


def _common_length(arrays):
    """The common batch length N of ``{name: (array, item_shape)}``.

    A single item (a scalar, or one (2,) centre) is broadcast; batched arrays
    must agree in length.
    """
    lengths = {name: arr.shape[0] for name, (arr, item) in arrays.items() if arr.ndim == len(item) + 1}
    if len(set(lengths.values())) > 1:
        desc = ", ".join(f"{name} has {n}" for name, n in lengths.items())
        raise RvtoolInputError(f"array lengths differ ({desc} entries); all array inputs must have one "
                               f"length N (a single value is broadcast to N)")
    return next(iter(lengths.values()), 1)


def _to_precision(name, arr, ndtype, positive):
    """Round ``arr`` to ``ndtype``; values outside its range are an error, not inf or 0."""
    with np.errstate(over="ignore", under="ignore"):
        out = np.ascontiguousarray(arr, dtype=ndtype)
    bad = ~np.isfinite(out) | ((out <= 0.0) if positive else False)
    if np.any(bad):
        fi = np.finfo(ndtype)
        raise RvtoolInputError(
            f"{name} = {float(np.asarray(arr)[bad].ravel()[0])!r} is not representable in {fi.dtype.name}; "
            f"valid magnitudes are [{fi.tiny:.3g}, {fi.max:.3g}] (or use precision='float64')")
    return out


def _prepare(specs, precision, device):
    """Check, broadcast to one length N and round the inputs described by ``specs``.

    ``specs`` maps a parameter name to ``(value, item_shape, low, low_open)``:
    ``item_shape`` is () for a scalar per entry or (2,) for a point, ``low``
    the lower bound of the valid range (None: any finite value). Returns the
    Warp dtype, the device, N and the rounded arrays in ``specs`` order.
    """
    wdtype, ndtype = scalar_types(precision)
    device = resolve_device(device)
    arrays = {}
    for name, (value, item, low, low_open) in specs.items():
        arr = _real_array(name, value)
        if arr.shape[arr.ndim - len(item):] != item or arr.ndim not in (len(item), len(item) + 1):
            want = ", ".join(["N", *map(str, item)])
            raise RvtoolInputError(f"{name} must have shape ({want}) or be a single value of shape "
                                   f"{item}; got shape {arr.shape}")
        if low is not None:
            check_range(name, arr, low, math.inf, low_open=low_open)
        arrays[name] = (arr, item)
    n = _common_length(arrays)
    out = [_to_precision(name, np.broadcast_to(arr, (n,) + item), ndtype, positive=bool(low_open))
           for (name, (arr, item)), (_, _, _, low_open) in zip(arrays.items(), specs.values())]
    return wdtype, device, n, out


def _launch(kernel, n, device, inputs, outputs):
    """Launch ``kernel`` over N entries and return its outputs as NumPy arrays.

    ``inputs`` are (NumPy array, Warp dtype) pairs, ``outputs`` (shape, Warp dtype) pairs.
    """
    w_in = [wp.array(a, dtype=dt, device=device) for a, dt in inputs]
    w_out = [wp.zeros(shape, dtype=dt, device=device) for shape, dt in outputs]
    if n > 0:
        wp.launch(kernel, dim=n, inputs=w_in, outputs=w_out, device=device)
    # numpy() waits for the device and copies to the host (on the CPU it is a view that keeps the buffer alive)
    return [a.numpy() for a in w_out]


# ---------------------------------------------------------------- public API

def eval_power_law(k, p, delta, precision="float64", device="cpu"):
    """Elastic power law F = k <delta>_+^p and dF/d delta, batched.

    Parameters
    ----------
    k : array_like (N,)
        Coefficient, N m^-p, k >= 0 (point contact p = 3/2: k_p; linearized
        line contact p = 1: k_l; output-pin law p = 10/9).
    p : array_like (N,)
        Exponent, dimensionless, p >= 1.
    delta : array_like (N,)
        Signed approach -g in m; only its positive part is an indentation.

    Returns
    -------
    F, dF_ddelta : ndarray (N,)
        Force in N and its derivative in N/m (zero for delta <= 0).
    """
    wdtype, device, n, ins = _prepare(
        {"k": (k, (), 0.0, False), "p": (p, (), 1.0, False), "delta": (delta, (), None, False)}, precision, device)
    return tuple(_launch(_kernels(wdtype)["power_law"], n, device, [(a, wdtype) for a in ins], [(n, wdtype)] * 2))


def eval_normal_force(k, p, c, delta_r, delta, delta_dot, precision="float64", device="cpu"):
    """Normal force of Eq. (normal_force) with the damping ramp, batched.

    F_n = max(0, k delta^p + c r(delta) delta_dot), r(delta) = min(delta/delta_r, 1)
    for delta > 0; an open contact (delta <= 0) carries no force.

    Parameters
    ----------
    k : array_like (N,)
        Elastic coefficient, N m^-p, k >= 0.
    p : array_like (N,)
        Exponent, p >= 1.
    c : array_like (N,)
        Damping coefficient, N s/m, c >= 0.
    delta_r : array_like (N,)
        Ramp indentation delta_r in m, > 0 (full damping for delta >= delta_r).
    delta : array_like (N,)
        Signed approach -g in m.
    delta_dot : array_like (N,)
        Approach rate in m/s.

    Returns
    -------
    F, dF_ddelta, dF_ddelta_dot : ndarray (N,)
        Force in N and its partials in N/m and N s/m (all zero when the
        force is clipped to zero, i.e. open contact or tensile damping).
    """
    wdtype, device, n, ins = _prepare(
        {"k": (k, (), 0.0, False), "p": (p, (), 1.0, False), "c": (c, (), 0.0, False),
         "delta_r": (delta_r, (), 0.0, True), "delta": (delta, (), None, False),
         "delta_dot": (delta_dot, (), None, False)}, precision, device)
    return tuple(_launch(_kernels(wdtype)["normal_force"], n, device, [(a, wdtype) for a in ins], [(n, wdtype)] * 3))


def eval_friction(mu_k, mu_s, v_s, v_reg, v, precision="float64", device="cpu"):
    """Regularized friction coefficient mu_reg(v) of Eq. (friction) and d mu_reg/dv, batched.

    mu_reg(v) = [mu_k + (mu_s - mu_k) exp(-(v/v_s)^2)] tanh(v/v_reg); the
    tangential force is F_t = -F_n mu_reg(v_t), dissipative (mu_reg(v) v >= 0)
    for mu_k, mu_s >= 0.

    Parameters
    ----------
    mu_k, mu_s : array_like (N,)
        Kinetic and static (Stribeck peak) coefficients, dimensionless, >= 0.
    v_s : array_like (N,)
        Stribeck velocity in m/s, > 0.
    v_reg : array_like (N,)
        Regularization velocity of the tanh in m/s, > 0.
    v : array_like (N,)
        Sliding velocity in m/s.

    Returns
    -------
    mu, dmu_dv : ndarray (N,)
        Coefficient (dimensionless) and its derivative in s/m.
    """
    wdtype, device, n, ins = _prepare(
        {"mu_k": (mu_k, (), 0.0, False), "mu_s": (mu_s, (), 0.0, False), "v_s": (v_s, (), 0.0, True),
         "v_reg": (v_reg, (), 0.0, True), "v": (v, (), None, False)}, precision, device)
    return tuple(_launch(_kernels(wdtype)["friction"], n, device, [(a, wdtype) for a in ins], [(n, wdtype)] * 2))


def eval_circle_contact(ca, cb, ra, rb, internal, k, p, precision="float64", device="cpu"):
    """Signed gap and elastic force on circle A of circle--circle contacts, batched.

    External (``internal`` false): g = |c_B - c_A| - r_A - r_B, the force on A
    points away from B. Internal (A inside the enclosing circle B of radius
    R_B = rb): g = R_B - r_A - |c_B - c_A|, the force on A points toward B's
    centre. Magnitude F_n = k <-g>_+^p.

    Parameters
    ----------
    ca, cb : array_like (N, 2)
        Centres of circles A and B in m (a single (2,) centre is broadcast).
    ra, rb : array_like (N,)
        Radii in m, > 0; for internal contact rb > ra.
    internal : array_like (N,) of bool or 0/1
        True for A inside B.
    k : array_like (N,)
        Coefficient in N m^-p, >= 0.
    p : array_like (N,)
        Exponent, >= 1.

    Returns
    -------
    gap : ndarray (N,)
        Signed gap in m (positive: separated).
    force_on_a : ndarray (N, 2)
        Force on circle A in N (the force on B is its negative).
    """
    flag = np.asarray(internal)
    if flag.dtype != np.bool_:
        vals = _real_array("internal", flag)
        if not np.all((vals == 0.0) | (vals == 1.0)):
            raise RvtoolInputError(f"internal must be boolean; got values {np.unique(vals)[:4].tolist()} "
                                   f"(valid choices: False/True or 0/1)")
        flag = vals != 0.0
    wdtype, device, n, (ca_, cb_, ra_, rb_, flag_, k_, p_) = _prepare(
        {"ca": (ca, (2,), None, False), "cb": (cb, (2,), None, False), "ra": (ra, (), 0.0, True),
         "rb": (rb, (), 0.0, True), "internal": (flag.astype(np.float64), (), None, False),
         "k": (k, (), 0.0, False), "p": (p, (), 1.0, False)}, precision, device)
    internal_ = flag_.astype(np.int32)
    bad = (internal_ != 0) & (rb_ <= ra_)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise RvtoolInputError(f"rb = {float(rb_[i])!r} m must exceed ra = {float(ra_[i])!r} m for an internal "
                               f"contact (entry {i}); valid range rb > ra > 0")
    kern = _kernels(wdtype)
    vec2 = kern["vec2"]
    inputs = [(ra_, wdtype), (rb_, wdtype), (internal_, wp.int32), (k_, wdtype), (p_, wdtype), (ca_, vec2), (cb_, vec2)]
    gap, force = _launch(kern["circle_contact"], n, device, inputs, [(n, wdtype), (n, vec2)])
    return gap, force.reshape(n, 2)
