"""Sampled peak load of each physical contact over the accepted steps.

A physical contact (a pin, a roller, a ball, a tooth pair) may be observed as
several rows (axial slices, laminae); its load at a step is the sum of its rows
(the force part of Eq. (width_resultant)), and its peak is the largest such sum
over the accepted steps. The per-row maxima of
:class:`~rvtool.observe.statistics.ExposureAccumulator` (``F_pk``) are the
slice peaks; their sum is not the contact peak (slices peak at different steps).
"""
import numpy as np

from ..model.reducer import physical_contact
from .registry import AcceptedStep


class ContactPeaks:
    """Observer: per physical contact, the largest per-step sum of its rows' normal forces [N]."""

    def __init__(self):
        self._index = {}                    # snapshot ids tuple -> (contact names, row -> contact index)
        self.peaks = {}                     # contact id -> peak [N]

    def _contacts(self, ids):
        if ids not in self._index:
            contact = [physical_contact(r) for r in ids]
            names = list(dict.fromkeys(contact))
            where = {c: k for k, c in enumerate(names)}
            self._index[ids] = (names, np.fromiter((where[c] for c in contact), int, len(contact)))
        return self._index[ids]

    def on_accepted(self, step: AcceptedStep) -> None:
        for snap in step.snapshots.values():
            names, rows = self._contacts(tuple(snap.ids))
            sums = np.bincount(rows, weights=np.asarray(snap.normal_force, float), minlength=len(names))
            for name, f in zip(names, sums):
                if f > self.peaks.get(name, -np.inf):
                    self.peaks[name] = float(f)

    def peak(self, prefix):
        """Largest contact peak [N] among contacts whose id starts with ``prefix``; None if none."""
        sel = [f for c, f in self.peaks.items() if c.startswith(prefix)]
        return max(sel) if sel else None

    def results(self) -> dict:
        return dict(self.peaks)
