"""Plane-strain half-space stress from normal and tangential surface tractions by Fourier transfer functions.

The body occupies z > 0 (z is the depth). Surface tractions on the body: pressure p(x) (positive in
compression, acting in +z) and tangential traction q(x) (positive in +x), i.e. sigma_zz(x, 0) = -p,
sigma_xz(x, 0) = -q (Johnson, *Contact Mechanics*, 1985, Sec. 2.2 conventions). For
p = P e^{ikx} and q = Q e^{ikx} the Airy stress function (A + B z) e^{-|k| z} e^{ikx} gives
(compression negative)

  normal:      sxx = -P (1 - |k| z) e^{-|k| z},  szz = -P (1 + |k| z) e^{-|k| z},  sxz = i k P z e^{-|k| z}
  tangential:  sxx = i Q (2 sgn k - k z) e^{-|k| z},  szz = i k Q z e^{-|k| z},  sxz = -Q (1 - |k| z) e^{-|k| z}

(both satisfy d sxx/dx + d sxz/dz = 0 and d sxz/dx + d szz/dz = 0 term by term; the inverse
transforms of a line load are Flamant's solutions, Johnson Eqs. 2.15 and 2.19), and
syy = nu (sxx + szz) in plane strain. At the surface the tangential part gives
sxx = -2 H[q] (H the Hilbert transform), i.e. 2 mu p0 of tension at the trailing edge of a
sliding Hertz contact. The discrete transform makes the loading periodic; zero padding to ``pad``
times the panel domain moves the images away. Their error in the stress maxima falls as pad^-2
(Hertz, domain +-3a: tau_max low by 7.4e-3, 1.9e-3, 4.7e-4 for pad = 4, 8, 16), hence the default 16.

Reported fields: tau_max = (lambda_max - lambda_min)/2 of the full plane-strain tensor (syy
included) and the von Mises stress.
"""
import numpy as np

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_range


def _principal_fields(sxx, szz, sxz, syy):
    tau_inplane = np.sqrt((0.5 * (sxx - szz)) ** 2 + sxz ** 2)
    c = 0.5 * (sxx + szz)
    s1, s3 = c + tau_inplane, c - tau_inplane
    smax = np.maximum(np.maximum(s1, s3), syy)
    smin = np.minimum(np.minimum(s1, s3), syy)
    vm = np.sqrt(0.5 * ((s1 - s3) ** 2 + (s3 - syy) ** 2 + (syy - s1) ** 2))
    return {"sxx": sxx, "szz": szz, "sxz": sxz, "syy": syy, "tau_max": 0.5 * (smax - smin), "von_mises": vm}


def subsurface_stress(x, pressure, z, nu=0.3, pad=16, *, traction=None, mu=0.0):
    """Stress fields on the grid (z, x) [Pa]: dict with sxx, szz, sxz, syy, tau_max, von_mises.

    x: uniform surface points [m] (panel centres); pressure: p(x) [Pa]; z: depths [m] (>= 0).
    Tangential traction q(x) [Pa] on the body along +x: ``traction`` given explicitly, or Coulomb
    sliding q = mu p with the signed coefficient ``mu`` (its sign is the sliding direction); the two
    are exclusive. nu: Poisson ratio of the equivalent material; pad: zero-padding factor (>= 2, see above).
    """
    x = np.asarray(x, float)
    p = np.asarray(pressure, float)
    n = x.size
    if n < 2 or p.shape != x.shape:
        raise RvtoolInputError(f"pressure: need one value per point of x ({n}); got shape {p.shape}")
    check_range("nu", nu, -1.0, 0.5)
    if not (isinstance(pad, (int, np.integer)) and pad >= 2):
        raise RvtoolInputError(f"pad = {pad!r} is outside the valid range: integers >= 2")
    if traction is not None and mu != 0.0:
        raise RvtoolInputError("traction and mu: give the tangential traction or the friction coefficient, not both")
    if not np.isfinite(mu) or abs(mu) > 1.0:
        raise RvtoolInputError(f"mu = {mu!r} is outside the valid range [-1, 1]")
    if traction is None:
        q = mu * p
    else:
        q = np.asarray(traction, float)
        if q.shape != x.shape:
            raise RvtoolInputError(f"traction: need one value per point of x ({n}); got shape {q.shape}")
    z = np.asarray(z, float)
    if z.ndim != 1 or np.any(z < 0):
        raise RvtoolInputError("z: need a 1-D array of depths >= 0 [m]")
    dx = x[1] - x[0]
    npad = pad * n
    k = 2 * np.pi * np.fft.rfftfreq(npad, dx)[None, :]
    P = np.fft.rfft(p, npad)[None, :]
    Q = np.fft.rfft(q, npad)[None, :] if np.any(q != 0) else None
    sxx, szz, sxz = (np.empty((z.size, n)) for _ in range(3))
    # depths in chunks: the spectra of one chunk are (chunk, npad/2) complex arrays
    chunk = max(1, int(4e6 // k.size))
    for i0 in range(0, z.size, chunk):
        zz = z[i0:i0 + chunk, None]
        e = np.exp(-k * zz)
        kz = k * zz
        Sxx = -P * (1 - kz) * e
        Szz = -P * (1 + kz) * e
        Sxz = 1j * k * P * zz * e
        if Q is not None:
            # rfft frequencies are >= 0: sgn k = 1 except at k = 0, where the tangential sxx vanishes
            Sxx += 1j * Q * (2 * np.sign(k) - kz) * e
            Szz += 1j * k * Q * zz * e
            Sxz -= Q * (1 - kz) * e
        sxx[i0:i0 + chunk] = np.fft.irfft(Sxx, npad)[:, :n]
        szz[i0:i0 + chunk] = np.fft.irfft(Szz, npad)[:, :n]
        sxz[i0:i0 + chunk] = np.fft.irfft(Sxz, npad)[:, :n]
    return _principal_fields(sxx, szz, sxz, nu * (sxx + szz))


def sliding_hertz_stress(x, z, halfwidth, p0, mu, nu=0.3):
    """Closed-form stress field [Pa] under p = p0 sqrt(1 - x^2/a^2) and q = mu p (sliding Hertz line
    contact; McEwen 1949, Johnson 1985 Eqs. 7.7-7.8) on the grid (z, x); same conventions and keys
    as :func:`subsurface_stress`. A reference for verification, independent of the FFT path.

    With m, n >= 0 and the signs of z and x respectively,
      m^2 = [sqrt((a^2 - x^2 + z^2)^2 + 4 x^2 z^2) + (a^2 - x^2 + z^2)] / 2,
      n^2 = [sqrt((a^2 - x^2 + z^2)^2 + 4 x^2 z^2) - (a^2 - x^2 + z^2)] / 2,
    normal part:     sxx = -(p0/a) [m (1 + (z^2 + n^2)/(m^2 + n^2)) - 2 z],
                     szz = -(p0/a) m (1 - (z^2 + n^2)/(m^2 + n^2)),
                     sxz = -(p0/a) n (m^2 - z^2)/(m^2 + n^2);
    tangential part (q0 = mu p0, q along +x):
                     sxx = (q0/a) [n (2 - (z^2 - m^2)/(m^2 + n^2)) - 2 x],
                     szz = -(q0/a) n (m^2 - z^2)/(m^2 + n^2),
                     sxz = -(q0/a) [m (1 + (z^2 + n^2)/(m^2 + n^2)) - 2 z].
    (signs for q along +x, checked against Flamant superposition, Johnson Eq. 2.23, in the tests;
    at the surface sxx = -p0 sqrt(1 - x^2/a^2) - 2 q0 x/a, tension 2 mu p0 at the trailing edge x = -a).
    """
    a = float(halfwidth)
    X = np.asarray(x, float)[None, :]
    Z = np.asarray(z, float)[:, None]
    s = a * a - X * X + Z * Z
    r = np.sqrt(s * s + 4 * X * X * Z * Z)
    m = np.sqrt(np.maximum(0.5 * (r + s), 0.0))
    n = np.sign(X) * np.sqrt(np.maximum(0.5 * (r - s), 0.0))
    d = m * m + n * n
    d = np.where(d > 0, d, np.inf)
    sxx = -(p0 / a) * (m * (1 + (Z * Z + n * n) / d) - 2 * Z)
    szz = -(p0 / a) * m * (1 - (Z * Z + n * n) / d)
    sxz = -(p0 / a) * n * (m * m - Z * Z) / d
    q0 = mu * p0
    sxx = sxx + (q0 / a) * (n * (2 - (Z * Z - m * m) / d) - 2 * X)
    szz = szz - (q0 / a) * n * (m * m - Z * Z) / d
    sxz = sxz - (q0 / a) * (m * (1 + (Z * Z + n * n) / d) - 2 * Z)
    return _principal_fields(sxx, szz, sxz, nu * (sxx + szz))
