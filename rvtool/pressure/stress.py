"""Plane-strain half-space stress from a normal surface pressure by Fourier transfer functions.

For p(x) with transform P(k), the fields at depth z are (compression negative)
  sxx = -P (1 - |k| z) e^{-|k| z},  szz = -P (1 + |k| z) e^{-|k| z},  sxz = i k P z e^{-|k| z}
(equilibrium checked term by term), syy = nu (sxx + szz).
"""
import numpy as np


def subsurface_stress(x, pressure, z, nu=0.3, pad=4):
    """Stress fields on the grid (z, x) [Pa]: dict with sxx, szz, sxz, syy, tau_max, von_mises."""
    x = np.asarray(x, float)
    n = x.size
    dx = x[1] - x[0]
    npad = pad * n
    P = np.fft.rfft(np.asarray(pressure, float), npad)
    k = 2 * np.pi * np.fft.rfftfreq(npad, dx)
    z = np.asarray(z, float)[:, None]
    e = np.exp(-k[None, :] * z)
    kz = k[None, :] * z
    sxx = np.fft.irfft(-P * (1 - kz) * e, npad)[:, :n]
    szz = np.fft.irfft(-P * (1 + kz) * e, npad)[:, :n]
    sxz = np.fft.irfft(1j * k * P * z * e, npad)[:, :n]
    syy = nu * (sxx + szz)
    tau_inplane = np.sqrt((0.5 * (sxx - szz)) ** 2 + sxz ** 2)
    c = 0.5 * (sxx + szz)
    s1, s3 = c + tau_inplane, c - tau_inplane
    smax = np.maximum(np.maximum(s1, s3), syy)
    smin = np.minimum(np.minimum(s1, s3), syy)
    vm = np.sqrt(0.5 * ((s1 - s3) ** 2 + (s3 - syy) ** 2 + (syy - s1) ** 2))
    return {"sxx": sxx, "szz": szz, "sxz": sxz, "syy": syy, "tau_max": 0.5 * (smax - smin), "von_mises": vm}
