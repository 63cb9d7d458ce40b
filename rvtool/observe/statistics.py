"""Per-contact exposure statistics of Eq. (obs_statistics).

For every contact identity c, over the accepted steps n added to it:

    I_F = sum_n F_{c,n} dt_n,   I_s = sum_n F_{c,n} |v_{s,c,n}| dt_n,
    I_m = sum_n F_{c,n}^m dt_n, F_pk = max_n F_{c,n},

plus the load-weighted position sum F x dt and normal sum F n dt that support
spatial source mappings. Integrals (:meth:`ExposureAccumulator.add`) and the
sampled maximum (:meth:`ExposureAccumulator.peak`) have separate update rules:
a peak is never weighted by time, and an integral never sees an evaluation
that was not an accepted state.

All tables are float64 whatever the kernels' precision, and the integrals are
compensated (Kahan) sums, so that long windows of many small steps do not
lose the late contributions and a window split reproduces the whole-run total
to round-off of the individual terms.
"""
import math

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive, check_range
from .registry import ContactSnapshot

# columns of the integral table
_IF, _IS, _IM, _TIME, _SLIP_TIME = 0, 1, 2, 3, 4
_POS = slice(5, 8)      # F x dt (2-D positions padded with z = 0)
_NRM = slice(8, 11)     # F n dt
_NRM_LOAD = 11          # F dt where a normal was given
_NCOL = 12
_CACHE_MAX = 64         # distinct id layouts remembered (sets whose active ids change)


class ExposureAccumulator:
    """Eq. (obs_statistics) per contact identity, in double precision.

    m: exponent of the load moment I_m (> 0, default 3) [-].

    Contact identities may appear in any later call: the tables grow, keyed
    by id, in order of first appearance (:attr:`ids`, :meth:`index`).
    Per-id arrays (float64, one entry per id):

    * ``I_F`` [N s], ``I_s`` [N m], ``I_m`` [N^m s], ``F_pk`` [N] (0 until a
      peak is recorded; forces are >= 0);
    * ``observed_time`` [s]: accumulated duration in which the id was in the
      snapshot; ``slip_time`` [s]: the part of it with a slip speed available
      (I_s covers only that part).

    :attr:`duration` [s] is the accumulated duration of all :meth:`add` calls.
    """

    def __init__(self, m: float = 3.0):
        check_finite("m", m)
        check_positive("m", m)
        self.m = float(m)
        self._ids = []
        self._index = {}
        self._cap = 0
        self._sum = np.zeros((0, _NCOL))
        self._comp = np.zeros((0, _NCOL))
        self._peak = np.zeros(0)
        self._dim = np.zeros(0, dtype=np.int8)
        self._dur = 0.0
        self._dur_comp = 0.0
        self._layout = {}

    # -- identities ------------------------------------------------------
    @property
    def ids(self) -> tuple:
        """Contact identities in table order."""
        return tuple(self._ids)

    def __len__(self):
        return len(self._ids)

    def index(self, contact_id: str) -> int:
        """Row of ``contact_id`` in the per-id arrays."""
        try:
            return self._index[contact_id]
        except KeyError:
            raise KeyError(f"contact id {contact_id!r} has not been observed by this accumulator "
                           f"({len(self._ids)} ids)") from None

    def _grow(self, n_new):
        need = len(self._ids) + n_new
        if need <= self._cap:
            return
        cap = max(need, 2 * self._cap, 16)
        n = len(self._ids)
        for name, width in (("_sum", _NCOL), ("_comp", _NCOL)):
            new = np.zeros((cap, width))
            new[:n] = getattr(self, name)[:n]
            setattr(self, name, new)
        peak = np.zeros(cap)
        peak[:n] = self._peak[:n]
        dim = np.zeros(cap, dtype=np.int8)
        dim[:n] = self._dim[:n]
        self._peak, self._dim, self._cap = peak, dim, cap

    def _rows_of(self, snapshots):
        """Row index (a slice when contiguous) for the concatenated ids of ``snapshots``.

        Layouts (ids and position dimension) are remembered, so that the
        checks below run once per layout rather than once per step.
        """
        key = tuple((s.ids, s.position.shape[1]) for s in snapshots)
        rows = self._layout.get(key)
        if rows is not None:
            return rows
        all_ids = [i for ids, _ in key for i in ids]
        if len(snapshots) > 1 and len(set(all_ids)) != len(all_ids):
            raise RvtoolInputError("ids must be unique across the snapshots of one accepted state; the contact "
                                   "sets share identities")
        new = [i for i in dict.fromkeys(all_ids) if i not in self._index]
        self._grow(len(new))
        for i in new:
            self._index[i] = len(self._ids)
            self._ids.append(i)
        idx = np.fromiter((self._index[i] for i in all_ids), dtype=np.intp, count=len(all_ids))
        if idx.size and np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size)):
            rows = slice(int(idx[0]), int(idx[0]) + idx.size)
        else:
            rows = idx
        dims = np.concatenate([np.full(len(ids), d, dtype=np.int8) for ids, d in key])
        old = self._dim[idx]
        clash = (old != 0) & (old != dims)
        if clash.any():
            bad = [all_ids[i] for i in np.flatnonzero(clash)[:4]]
            raise RvtoolInputError(f"position of contacts {bad} changed from {int(old[clash][0])} to "
                                   f"{int(dims[clash][0])} coordinates; valid: the same 2 or 3 coordinates "
                                   "at every step")
        self._dim[idx] = dims
        if len(self._layout) >= _CACHE_MAX:
            self._layout.clear()
        self._layout[key] = rows
        return rows

    # -- update rules ----------------------------------------------------
    def add(self, dt_weight: float, *snapshots: ContactSnapshot) -> None:
        """Integrate ``snapshots`` (all at one accepted state) over ``dt_weight`` [s] (>= 0).

        Adds F dt, F |v_s| dt, F^m dt, F x dt, F n dt and dt to the ids of the
        snapshots (Eq. (obs_statistics)); the peak is left to :meth:`peak`.
        ``duration`` advances by dt_weight once per call, also without snapshots.
        """
        dt = float(dt_weight)
        if not (0.0 <= dt < math.inf):  # plain-float test: this runs for every step and window part
            check_finite("dt_weight", dt_weight)
            check_range("dt_weight", dt_weight, 0.0)
        self._dur, self._dur_comp = _kahan_scalar(self._dur, self._dur_comp, dt)
        snapshots = _checked(snapshots)
        if not snapshots:
            return
        rows = self._rows_of(snapshots)
        n = sum(len(s) for s in snapshots)
        x = np.zeros((n, _NCOL))
        r = 0
        for s in snapshots:
            k = len(s)
            blk = x[r:r + k]
            fdt = np.asarray(s.normal_force, dtype=np.float64) * dt
            blk[:, _IF] = fdt
            blk[:, _IM] = np.power(np.asarray(s.normal_force, dtype=np.float64), self.m) * dt
            blk[:, _TIME] = dt
            if s.slip_speed is not None:
                blk[:, _IS] = fdt * np.abs(np.asarray(s.slip_speed, dtype=np.float64))
                blk[:, _SLIP_TIME] = dt
            d = s.position.shape[1]
            blk[:, 5:5 + d] = fdt[:, None] * np.asarray(s.position, dtype=np.float64)
            if s.normal is not None:
                blk[:, 8:8 + d] = fdt[:, None] * np.asarray(s.normal, dtype=np.float64)
                blk[:, _NRM_LOAD] = fdt
            r += k
        # Kahan compensated sum, row-wise (rows are unique ids); the table value is sum - comp
        s_old = self._sum[rows]
        y = x - self._comp[rows]
        t = s_old + y
        self._comp[rows] = (t - s_old) - y
        self._sum[rows] = t

    def peak(self, *snapshots: ContactSnapshot) -> None:
        """Update F_pk = max(F_pk, F) for the ids of ``snapshots`` (sampled maximum, never integrated)."""
        snapshots = _checked(snapshots)
        if not snapshots:
            return
        rows = self._rows_of(snapshots)
        f = np.concatenate([np.asarray(s.normal_force, dtype=np.float64) for s in snapshots])
        self._peak[rows] = np.maximum(self._peak[rows], f)

    # -- results ---------------------------------------------------------
    def _col(self, c):
        n = len(self._ids)
        return self._sum[:n, c] - self._comp[:n, c]

    @property
    def duration(self) -> float:
        """Accumulated duration of all :meth:`add` calls [s]."""
        return self._dur - self._dur_comp

    @property
    def I_F(self) -> np.ndarray:
        """sum F dt per id [N s] (Eq. (obs_statistics))."""
        return self._col(_IF)

    @property
    def I_s(self) -> np.ndarray:
        """sum F |v_s| dt per id [N m] (Eq. (obs_statistics)); over ``slip_time`` only."""
        return self._col(_IS)

    @property
    def I_m(self) -> np.ndarray:
        """sum F^m dt per id [N^m s] (Eq. (obs_statistics))."""
        return self._col(_IM)

    @property
    def F_pk(self) -> np.ndarray:
        """max F per id [N] (Eq. (obs_statistics)); 0 where no peak was recorded."""
        return self._peak[:len(self._ids)].copy()

    @property
    def observed_time(self) -> np.ndarray:
        """Duration each id was present in the added snapshots [s]."""
        return self._col(_TIME)

    @property
    def slip_time(self) -> np.ndarray:
        """Duration each id had a slip speed available [s]."""
        return self._col(_SLIP_TIME)

    def _weighted(self, cols, load_col):
        n = len(self._ids)
        num = self._sum[:n, cols] - self._comp[:n, cols]
        den = self._col(load_col)
        out = {}
        for i, cid in enumerate(self._ids):
            d = int(self._dim[i]) or 3
            out[cid] = num[i, :d] / den[i] if den[i] > 0.0 else None
        return out

    def load_weighted_position(self) -> dict:
        """id -> sum(F x dt) / sum(F dt) [m] (2 or 3 components), None where the id carried no load."""
        return self._weighted(_POS, _IF)

    def load_weighted_normal(self) -> dict:
        """id -> sum(F n dt) / sum(F dt) over the steps with a normal [-], None where none was loaded.

        Not renormalized: its length (<= 1) shows how much the normal turned under load.
        """
        return self._weighted(_NRM, _NRM_LOAD)

    def to_dict(self) -> dict:
        """Per-id float64 arrays (and lists of per-id vectors or None), with units in the key docs above."""
        pos = self.load_weighted_position()
        nrm = self.load_weighted_normal()
        return {
            "ids": list(self._ids),
            "m": self.m,
            "duration": self.duration,
            "I_F": self.I_F,
            "I_s": self.I_s,
            "I_m": self.I_m,
            "F_pk": self.F_pk,
            "observed_time": self.observed_time,
            "slip_time": self.slip_time,
            "load_weighted_position": [None if v is None else v.tolist() for v in pos.values()],
            "load_weighted_normal": [None if v is None else v.tolist() for v in nrm.values()],
        }


def _kahan_scalar(s, c, x):
    y = x - c
    t = s + y
    return t, (t - s) - y


def _checked(snapshots):
    for s in snapshots:
        if not isinstance(s, ContactSnapshot):
            raise RvtoolInputError(f"snapshot must be a ContactSnapshot; got {type(s).__name__}")
    return snapshots
