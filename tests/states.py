"""Comparison of solved states shared by the backend tests (not a test module)."""
import numpy as np


def assert_equal_states(q, q_ref, model, tol):
    """Each coordinate kind (rotations, translations) of ``q`` within ``tol`` relative to the largest
    deviation of that kind in ``q_ref`` (the states of ``model``'s nodes, in its coordinates)."""
    q, q_ref = np.asarray(q), np.asarray(q_ref)
    rot = np.zeros(q.shape[-1], bool)
    for n in model.nodes:
        rot[np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int)[2]] = True
    for kind in (rot, ~rot):
        scale = np.max(np.abs(q_ref[..., kind]))
        assert np.max(np.abs(q[..., kind] - q_ref[..., kind])) <= tol * scale
