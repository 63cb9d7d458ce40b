"""Warp kernels: the cycloid profile tables of many wheel profiles computed on the device.

A Monte Carlo variant of a cycloid drive draws its wheel profile (equidistant and offset
modifications, the generating eccentricity's error), so each variant's wheels have their own
contact-search tables. Computed on the host they are most of a variant's build (RD-40: ~8 of
~13 ms) and of its snapshot (2 x 262 kB). These kernels compute them from the profiles'
parameters on the device, the host's operations of :meth:`rvtool.geometry.cycloid.CycloidProfile.table`,
:func:`rvtool.contact.cycloid_set.pin_curve_table` and :func:`~rvtool.contact.cycloid_set.auto_window`
one for one (equal to rounding: the device's sine and cosine are its own):

1. ``dense_lengths`` (a thread per table and dense angle): the profile point at the dense angles
   j 2 pi / N_d and at the next one (turned by the rotation modification), their distance;
2. ``arc_lengths`` (a thread per table): the cumulative arc length in order (numpy's cumsum, four loads in
   flight);
3. ``resampled`` (a thread per table and sample): the generating angle at equal arc length
   (numpy's interp: the bracketing dense interval by bisection, its slope), the point, outward
   normal, curvature and polar angle there;
4. ``probe_angles`` (a thread per table and sample): the polar angle of the pin-centre curve P + r_p N;
   ``keyed`` (a thread per table): the samples ordered by polar angle (the profile is star-shaped,
   its polar angle monotone along the samples: the order is a rotation of the sample order, checked),
   the search key (that angle, checked monotone over one turn) and where the table turned to start at
   the key's smallest value begins; ``permuted`` (a thread per table and sample): the table in that
   order (the serial pass reads one angle per sample, it no longer evaluates or copies);
5. ``window_offsets`` (a thread per table and sample, looping over the probe distances): the index distance
   of each probe's key bisection from its sample, the largest per table (one atomic max per sample).

A table that fails a check (``ok`` 0) is left to the host. NumPy reference: the host functions above.
Float64 only.
"""
import functools
import time

import numpy as np
import warp as wp

TWO_PI = 6.283185307179586
"""2 pi as numpy's float64 (the host's np.pi * 2)."""


@functools.lru_cache(maxsize=None)
def _kernels():
    f64 = wp.float64

    @wp.func
    def unrotated(phi: f64, R: f64, K1: f64, zb: f64, nz: int, rc: f64):
        # CycloidProfile._unrotated_points with _epitrochoid (the table's dense grid: _dense_unrotated)
        s = wp.sin(phi)
        c = wp.cos(phi)
        zp = f64(nz) * phi
        S = wp.sin(zp)
        C = wp.cos(zp)
        ex = R * (s - K1 / zb * S)
        ey = R * (c - K1 / zb * C)
        dx = R * (c - K1 * C)
        dy = R * (-s + K1 * S)
        D = wp.sqrt(dx * dx + dy * dy) / R
        wx = (K1 * S - s) / D
        wy = (K1 * C - c) / D
        return wp.vec2d(ex + rc * wx, ey + rc * wy)

    @wp.func
    def turned(v: wp.vec2d, cr: f64, sr: f64, on: int):
        if on == 0:
            return v
        return wp.vec2d(cr * v[0] - sr * v[1], sr * v[0] + cr * v[1])

    @wp.func
    def unwrap_step(st: f64):
        # np.unwrap's step: a difference of two angles reduced to [-pi, pi)
        st = wp.mod(st + f64(3.141592653589793), f64(TWO_PI))
        if st < f64(0.0):
            st = st + f64(TWO_PI)
        return st - f64(3.141592653589793)

    @wp.func
    def pmod(a: f64):
        # np.mod(a, 2 pi) for a in [-pi, pi] (atan2's range): fmod is a, a negative one moves up by 2 pi
        if a < f64(0.0):
            return a + f64(TWO_PI)
        return a

    @wp.kernel
    def dense_lengths(prm: wp.array2d(dtype=f64), nz: wp.array(dtype=wp.int32), n_dense: int, step: f64,
                      seg: wp.array2d(dtype=f64)):
        t, j = wp.tid()
        R = prm[t, 0]
        K1 = prm[t, 1]
        zb = prm[t, 2]
        rc = prm[t, 3]
        cr = prm[t, 4]
        sr = prm[t, 5]
        on = int(prm[t, 6])
        a = turned(unrotated(f64(j) * step, R, K1, zb, nz[t], rc), cr, sr, on)
        jn = j + 1
        if jn == n_dense:
            jn = 0
        b = turned(unrotated(f64(jn) * step, R, K1, zb, nz[t], rc), cr, sr, on)
        d = b - a
        seg[t, j + 1] = wp.sqrt(d[0] * d[0] + d[1] * d[1])

    @wp.kernel
    def arc_lengths(n_dense: int, s: wp.array2d(dtype=f64), total: wp.array(dtype=f64)):
        t = wp.tid()
        acc = f64(0.0)
        s[t, 0] = acc
        # numpy's cumsum, in its order; four segment lengths loaded before they are summed in (the pass is
        # one thread per table and waits on memory: four loads in flight instead of one)
        j = int(0)
        while j + 4 <= n_dense:
            a0 = s[t, j + 1]
            a1 = s[t, j + 2]
            a2 = s[t, j + 3]
            a3 = s[t, j + 4]
            acc = acc + a0
            s[t, j + 1] = acc
            acc = acc + a1
            s[t, j + 2] = acc
            acc = acc + a2
            s[t, j + 3] = acc
            acc = acc + a3
            s[t, j + 4] = acc
            j = j + 4
        while j < n_dense:
            acc = acc + s[t, j + 1]
            s[t, j + 1] = acc
            j = j + 1
        total[t] = acc

    @wp.kernel
    def resampled(prm: wp.array2d(dtype=f64), nz: wp.array(dtype=wp.int32), s: wp.array2d(dtype=f64),
                  n_dense: int, step: f64, n: int,
                  pts: wp.array3d(dtype=f64), nrm: wp.array3d(dtype=f64), kap: wp.array2d(dtype=f64),
                  polar: wp.array2d(dtype=f64), phi_out: wp.array2d(dtype=f64)):
        t, i = wp.tid()
        R = prm[t, 0]
        K1 = prm[t, 1]
        zb = prm[t, 2]
        rc = prm[t, 3]
        cr = prm[t, 4]
        sr = prm[t, 5]
        on = int(prm[t, 6])
        total = s[t, n_dense]
        x = f64(i) * total / f64(n)
        # np.interp(x, s, [dense, 2 pi]): s[j] <= x < s[j + 1]
        lo = int(0)
        hi = n_dense
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if s[t, mid] <= x:
                lo = mid
            else:
                hi = mid
        p0 = f64(lo) * step
        p1 = f64(TWO_PI)
        if lo + 1 < n_dense:
            p1 = f64(lo + 1) * step
        slope = (p1 - p0) / (s[t, lo + 1] - s[t, lo])
        phi = slope * (x - s[t, lo]) + p0
        # CycloidProfile.table at phi: points, tangents, curvature
        sn = wp.sin(phi)
        c = wp.cos(phi)
        zp = f64(nz[t]) * phi
        S = wp.sin(zp)
        C = wp.cos(zp)
        ex = R * (sn - K1 / zb * S)
        ey = R * (c - K1 / zb * C)
        dx = R * (c - K1 * C)
        dy = R * (-sn + K1 * S)
        ddx = R * (-sn + K1 * zb * S)
        ddy = R * (-c + K1 * zb * C)
        speed = wp.sqrt(dx * dx + dy * dy)
        D = speed / R
        p = turned(wp.vec2d(ex + rc * ((K1 * S - sn) / D), ey + rc * ((K1 * C - c) / D)), cr, sr, on)
        tg = turned(wp.vec2d(dx / speed, dy / speed), cr, sr, on)
        cross = dx * ddy - dy * ddx
        kE = -cross / (speed * speed * speed)
        pts[t, i, 0] = p[0]
        pts[t, i, 1] = p[1]
        nrm[t, i, 0] = -tg[1]
        nrm[t, i, 1] = tg[0]
        kap[t, i] = kE / (f64(1.0) - rc * kE)
        polar[t, i] = pmod(wp.atan2(p[1], p[0]))
        phi_out[t, i] = phi

    @wp.kernel
    def probe_angles(rp: wp.array(dtype=f64), pts: wp.array3d(dtype=f64), nrm: wp.array3d(dtype=f64),
                     ang: wp.array2d(dtype=f64)):
        # the polar angle of the pin-centre curve P + r_p N at each sample (pin_curve_table's key before mod 2 pi)
        t, i = wp.tid()
        r = rp[t]
        ang[t, i] = wp.atan2(pts[t, i, 1] + r * nrm[t, i, 1], pts[t, i, 0] + r * nrm[t, i, 0])

    @wp.kernel
    def keyed(n: int, polar: wp.array2d(dtype=f64), ang: wp.array2d(dtype=f64), order: wp.array2d(dtype=wp.int32),
              ok: wp.array(dtype=wp.int32)):
        t = wp.tid()
        # the order of increasing polar angle: from the smallest, along the samples or against them
        m = int(0)
        for i in range(1, n):
            if polar[t, i] < polar[t, m]:
                m = i
        d = int(1)
        if polar[t, (m + n - 1) % n] < polar[t, (m + 1) % n]:
            d = n - 1
        good = int(1)
        for k in range(1, n):
            if polar[t, (m + d * k) % n] <= polar[t, (m + d * (k - 1)) % n]:
                good = 0
        # pin_curve_table: the key (polar angle of P + r_p N) monotone over one turn, the table turned to
        # start at its smallest value
        k0 = int(0)
        kmin = f64(1.0e30)
        total = f64(0.0)
        prev = f64(0.0)
        first = f64(0.0)
        for k in range(n):
            a = ang[t, (m + d * k) % n]
            if k == 0:
                first = a
            else:
                st = unwrap_step(a - prev)
                if st <= f64(0.0):
                    good = 0
                total = total + st
            prev = a
            ka = pmod(a)
            if ka < kmin:
                kmin = ka
                k0 = k
        st = unwrap_step(first - prev)
        if st <= f64(0.0):
            good = 0
        total = total + st
        if wp.abs(total - f64(TWO_PI)) >= f64(1.0e-9):
            good = 0
        ok[t] = good
        order[t, 0] = m
        order[t, 1] = d
        order[t, 2] = k0

    @wp.kernel
    def permuted(n: int, order: wp.array2d(dtype=wp.int32), pts: wp.array3d(dtype=f64), nrm: wp.array3d(dtype=f64),
                 kap: wp.array2d(dtype=f64), ang: wp.array2d(dtype=f64), phi: wp.array2d(dtype=f64),
                 o_pts: wp.array3d(dtype=f64), o_nrm: wp.array3d(dtype=f64), o_kap: wp.array2d(dtype=f64),
                 o_key: wp.array2d(dtype=f64), o_phi: wp.array2d(dtype=f64)):
        # the table in key order (keyed's order: sample k of the output is sample i of the resampled profile)
        t, k = wp.tid()
        i = (order[t, 0] + order[t, 1] * ((k + order[t, 2]) % n)) % n
        o_pts[t, k, 0] = pts[t, i, 0]
        o_pts[t, k, 1] = pts[t, i, 1]
        o_nrm[t, k, 0] = nrm[t, i, 0]
        o_nrm[t, k, 1] = nrm[t, i, 1]
        o_kap[t, k] = kap[t, i]
        o_phi[t, k] = phi[t, i]
        o_key[t, k] = pmod(ang[t, i])

    @wp.kernel
    def window_offsets(n: int, n_dist: int, rp: wp.array(dtype=f64), dist: wp.array(dtype=f64),
                       pts: wp.array3d(dtype=f64), nrm: wp.array3d(dtype=f64), key: wp.array2d(dtype=f64),
                       off: wp.array(dtype=wp.int32)):
        t, i = wp.tid()
        h = n // 2
        worst = int(0)
        for q in range(n_dist):
            r = rp[t] * dist[q]
            beta = pmod(wp.atan2(pts[t, i, 1] + r * nrm[t, i, 1], pts[t, i, 0] + r * nrm[t, i, 0]))
            # np.searchsorted(key, beta) (side left): the first index whose key is >= beta
            lo = int(0)
            hi = n
            while lo < hi:
                mid = (lo + hi) // 2
                if key[t, mid] < beta:
                    lo = mid + 1
                else:
                    hi = mid
            x = ((lo - i) + h) % n
            if x < 0:
                x = x + n
            worst = wp.max(worst, wp.abs(x - h))
        # one atomic per sample (its probes' largest offset) instead of one per probe: the table's maximum
        wp.atomic_max(off, t, worst)

    return dense_lengths, arc_lengths, resampled, probe_angles, keyed, permuted, window_offsets


STAGES = ("upload", "dense_lengths", "arc_lengths", "resampled", "keyed", "window_offsets")
"""The stages of :func:`launch_profile_tables` whose times ``timing`` receives (and "read":
:meth:`PendingTables.finish`)."""


class PendingTables:
    """The profile tables of one launch (:func:`launch_profile_tables`): ``columns`` (points (T, n, 2),
    normals (T, n, 2), curvature (T, n), key (T, n), phi (T, n)) are Warp arrays on the device, written by
    kernels that may still run; :meth:`finish` waits for them and reads the few host numbers (spacing,
    window, ok) once."""

    def __init__(self, columns, host_arrays, n, margin, device, timing, events, scratch):
        self.columns, self._host_arrays, self._n, self._margin = tuple(columns), host_arrays, n, margin
        self._device, self._timing, self._events, self._done = device, timing, events, None
        self._scratch = scratch         # the kernels' inputs and intermediates, alive until they have run

    def finish(self):
        """(spacing (T,) [m], window (T,) [samples], ok (T,) bool) as NumPy (the device waited for once)."""
        if self._done is None:
            t0 = time.perf_counter()
            total, off, ok = (a.numpy() for a in self._host_arrays)   # (not the arc-length table: ~1 GB a launch)
            self._done = (total / self._n, np.ceil(self._margin * off).astype(int) + 2, ok == 1)
            if self._timing is not None:
                if self._events:                # CUDA: each stage's time from its events, read now (no waits before)
                    for name, (a, b) in zip(STAGES, zip(self._events[:-1], self._events[1:])):
                        self._timing[name] = self._timing.get(name, 0.0) + 1e-3 * wp.get_event_elapsed_time(a, b)
                self._timing["read"] = self._timing.get("read", 0.0) + time.perf_counter() - t0
            self._host_arrays = self._events = self._scratch = None
        return self._done


def launch_profile_tables(params, n_pins, rp, n_samples, n_dense, band, device="cpu", margin=1.5, timing=None):
    """Launch the kernels of :func:`profile_tables` on Warp ``device`` without waiting for them: a
    :class:`PendingTables` (the caller's host work runs while the device computes; its ``finish`` waits).
    timing: None, or a dict that receives each stage's time [s] added to its entry (:data:`STAGES`: on a
    CUDA device from events recorded between the stages and read at ``finish``, nothing waited for before;
    on the cpu, whose launches run as they are made, the wall time of each; "read": ``finish``'s wait and
    read-back)."""
    dense_lengths, arc_lengths, resampled, probe_angles, keyed, permuted, window_offsets = _kernels()
    d = device
    cuda = timing is not None and not wp.get_device(d).is_cpu
    events, clock = [], [time.perf_counter()]

    def stage(name):
        if timing is None:
            return
        if cuda:
            events.append(wp.get_stream(d).record_event(wp.Event(d, enable_timing=True)))
        elif name is not None:
            now = time.perf_counter()
            timing[name] = timing.get(name, 0.0) + now - clock[0]
            clock[0] = now
    stage(None)
    params = np.asarray(params, np.float64)
    T, n, nd = len(params), int(n_samples), int(n_dense)
    rot = params[:, 4]
    prm = np.zeros((T, 7))
    prm[:, :4] = params[:, :4]
    prm[:, 4], prm[:, 5], prm[:, 6] = np.cos(rot), np.sin(rot), (rot != 0.0)
    step = (TWO_PI - 0.0) / nd                      # np.linspace(0, 2 pi, nd, endpoint=False)'s step
    prm_d = wp.array(prm, dtype=wp.float64, device=d)
    nz_d = wp.array(np.asarray(n_pins, np.int32), dtype=wp.int32, device=d)
    rp_d = wp.array(np.asarray(rp, np.float64), dtype=wp.float64, device=d)
    s = wp.empty((T, nd + 1), dtype=wp.float64, device=d)      # every entry written (dense_lengths, arc_lengths)
    total_d = wp.zeros(T, dtype=wp.float64, device=d)
    dist = wp.array(np.linspace(1.0 - band, 1.0 + band, 9), dtype=wp.float64, device=d)
    stage("upload")
    wp.launch(dense_lengths, dim=(T, nd), inputs=[prm_d, nz_d, nd, step, s], device=d)
    stage("dense_lengths")
    wp.launch(arc_lengths, dim=T, inputs=[nd, s, total_d], device=d)
    stage("arc_lengths")
    raw = [wp.empty((T, n, 2), dtype=wp.float64, device=d), wp.empty((T, n, 2), dtype=wp.float64, device=d)] + \
        [wp.empty((T, n), dtype=wp.float64, device=d) for _ in range(3)]
    wp.launch(resampled, dim=(T, n), inputs=[prm_d, nz_d, s, nd, step, n] + raw, device=d)
    stage("resampled")
    out = [wp.empty((T, n, 2), dtype=wp.float64, device=d), wp.empty((T, n, 2), dtype=wp.float64, device=d)] + \
        [wp.empty((T, n), dtype=wp.float64, device=d) for _ in range(3)]
    ok = wp.zeros(T, dtype=wp.int32, device=d)
    ang = wp.empty((T, n), dtype=wp.float64, device=d)
    order = wp.empty((T, 3), dtype=wp.int32, device=d)
    pts_r, nrm_r, kap_r, polar_r, phi_r = raw
    wp.launch(probe_angles, dim=(T, n), inputs=[rp_d, pts_r, nrm_r, ang], device=d)
    wp.launch(keyed, dim=T, inputs=[n, polar_r, ang, order, ok], device=d)
    wp.launch(permuted, dim=(T, n), inputs=[n, order, pts_r, nrm_r, kap_r, ang, phi_r] + out, device=d)
    stage("keyed")
    off = wp.zeros(T, dtype=wp.int32, device=d)
    wp.launch(window_offsets, dim=(T, n), inputs=[n, 9, rp_d, dist, out[0], out[1], out[3], off], device=d)
    stage("window_offsets")
    return PendingTables(out, (total_d, off, ok), n, margin, d, timing, events,
                         (prm_d, nz_d, rp_d, s, dist, raw, ang, order))


def profile_tables(params, n_pins, rp, n_samples, n_dense, band, device="cpu", margin=1.5, as_numpy=True,
                   timing=None):
    """Profile tables of T profiles on Warp ``device`` (module docstring).

    params (T, 5): per profile R (pin-circle radius plus offset modification) [m], K1 [-], z_b
    (float), r_c (generating radius) [m], rotation [rad]; n_pins (T,) z_b; rp (T,) the pin radius of
    the key and window [m]; n_samples, n_dense (the host's 16 n_samples): counts; band: the window's
    search band (fraction of r_p). Returns (points (T, n, 2), normals (T, n, 2), curvature (T, n),
    key (T, n), spacing (T,), phi (T, n), window (T,), ok (T,) bool), the five table columns as NumPy
    arrays (``as_numpy``) or as the Warp device arrays (left on the device), the rest NumPy: table t is
    (points[t], normals[t], curvature[t], key[t], spacing[t], phi[t]) of
    ``pin_curve_table(profile.table(n_samples), rp)`` and its ``auto_window`` where ok[t].
    timing: see :func:`launch_profile_tables` (this function waits for the launch)."""
    pending = launch_profile_tables(params, n_pins, rp, n_samples, n_dense, band, device, margin, timing)
    h, window, ok = pending.finish()
    pts, nrm, kap, key, phi = (a.numpy() for a in pending.columns) if as_numpy else pending.columns
    return pts, nrm, kap, key, h, phi, window, ok


__all__ = ["PendingTables", "STAGES", "launch_profile_tables", "profile_tables"]
