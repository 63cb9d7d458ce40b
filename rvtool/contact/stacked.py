"""Several contact sets over the same bodies evaluated as one set: the contacts that one
series closure balances together (an RV crank's journals and gear, loaded by the needle
bearings and the involute mesh, closed by the crank beam in :mod:`rvtool.contact.pin_closure`).

Generalized forces and tangents add (every part is an evaluator over the same ``n_bodies``
absolute poses); the observation rows are the parts' rows in order, so a family keeps its rows
as a contiguous range (:attr:`StackedContactSet.rows`). The shared observation columns
(:mod:`warp_contacts.circle_pairs_ref`, the first eight) come first in every family; a family's
extra columns (the involute meshes' tooth-pair data) are zero on the other families' rows. The parts must carry no contact history
(frictionless or regularized-friction sets): a closure evaluates its inner set at deflected
station poses that the element does not commit, so anchors could not be committed consistently.
"""
import numpy as np

from ..errors import RvtoolInputError
from .evaluator import Evaluation


class StackedContactSet:
    """The evaluator protocol of :class:`exudyn_user_elements.contact_element.ContactElement`
    over ``parts`` (contact evaluators with equal ``n_bodies``), named ``name``."""

    def __init__(self, parts, *, name):
        parts = tuple(parts)
        if not parts:
            raise RvtoolInputError("parts must hold at least one contact set (got 0)")
        nb = {int(p.n_bodies) for p in parts}
        if len(nb) != 1:
            raise RvtoolInputError(f"parts have n_bodies {[p.n_bodies for p in parts]}; a stacked set needs one "
                                   "body count")
        for p in parts:
            if any(isinstance(v, np.ndarray) for v in vars(p.history).values()):
                raise RvtoolInputError(f"contact set {p.name!r} carries a contact history (friction anchors); a "
                                       "stacked set takes history-free parts only (valid: frictionless or "
                                       "regularized friction)")
        self.parts = parts
        self.name = name
        self.n_bodies = nb.pop()
        self.ids = tuple(i for p in parts for i in p.ids)
        ends = np.cumsum([0] + [len(p.ids) for p in parts])
        #: {part name: row indices of the part's observation rows in the stacked set}
        self.rows = {p.name: np.arange(ends[k], ends[k + 1]) for k, p in enumerate(parts)}
        self.history = parts[0].history          # history-free (checked above)

    def part(self, name):
        """The part named ``name``."""
        for p in self.parts:
            if p.name == name:
                return p
        raise RvtoolInputError(f"part = {name!r}; valid: {[p.name for p in self.parts]}")

    def evaluate(self, pose, vel, history=None, check=True):
        evs = [p.evaluate(pose, vel, check=check) for p in self.parts]
        Q = np.sum([e.Q for e in evs], axis=0)
        dQdq = np.sum([e.dQdq for e in evs], axis=0)
        dQdv = None if any(e.dQdv is None for e in evs) else np.sum([e.dQdv for e in evs], axis=0)
        return Evaluation(Q, dQdq, dQdv, stack_rows([e.obs for e in evs]), (), all(e.finite for e in evs))

    def commit(self, pose, vel, evaluation=None):
        """Observation rows at the accepted state (no history to commit)."""
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return stack_rows([p.commit(pose, vel) for p in self.parts])

    def resultants(self, pose, vel=None):
        """The parts' ``resultants`` (per mounting) in one dict (parts without them are skipped)."""
        out = {}
        for p in self.parts:
            if callable(getattr(p, "resultants", None)):
                out.update(p.resultants(pose, vel))
        return out

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per stacked row, passed to each part that takes them; a nonzero offset
        on a part that takes none is an error naming it."""
        off = np.asarray(offsets, float)
        if off.shape != (len(self.ids),):
            raise RvtoolInputError(f"gap offsets of contact set {self.name!r} must have shape ({len(self.ids)},); "
                                   f"got {off.shape}")
        for p in self.parts:
            o = off[self.rows[p.name]]
            if callable(getattr(p, "set_gap_offsets", None)):
                p.set_gap_offsets(o)
            elif np.any(o != 0.0):
                raise RvtoolInputError(f"contact set {p.name!r} ({type(p).__name__}) takes no gap offsets; valid: "
                                       "zero offsets on its rows")


def stack_rows(blocks):
    """The observation blocks (rows_k, cols_k) one below the other, zero-padded to the widest."""
    width = max(b.shape[1] for b in blocks)
    return np.vstack([np.pad(np.asarray(b, float), ((0, 0), (0, width - b.shape[1]))) for b in blocks])
