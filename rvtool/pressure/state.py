"""Undeformed gap at a selected pin contact of an accepted state (Eqs. public_pressure_pose, public_pressure_tangent).

The wheel profile is placed at its final pose; the local frame is the
five-point tangent of the profile at the contact point and the normal of the
contact observation; the pin enters through its mating-circle branch (the side
facing the wheel). The contact point and its load are fixed before any
resolution is chosen, so refining the panel grid never reselects the contact.
"""
import numpy as np

from rvtool.geometry.cycloid import pin_centres


def _wheel_points(profile, pose, phi):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    p = profile.points(phi)
    return np.stack([c * p[:, 0] - s * p[:, 1] + pose[0], s * p[:, 0] + c * p[:, 1] + pose[1]], axis=-1)


def pin_contact_gap(model, q, contact, x):
    """Gap [m] at local coordinates x [m] along the tangent for cycloid pin contact index ``contact``.

    Returns (gap, force [N]). The gap datum is its minimum (absorbed by the approach)."""
    el = model.elements["pins"]
    ql = el.local(q)
    pose, _ = el.pose_velocity(ql, 0 * ql)
    obs = el.evaluate(0.0, ql, 0 * ql).obs[contact]
    mesh_id = model.pin_set.mesh_of[contact]
    pin = int(model.pin_set.pin_of[contact])
    mesh = model.pin_set.meshes[int(mesh_id)]
    prof = mesh.profile
    wpose = pose[mesh.wheel_body]
    pc = np.asarray(obs[3:5]); nrm = np.asarray(obs[5:7]) / np.linalg.norm(obs[5:7])
    # nearest profile parameter to the contact point
    phi = np.linspace(0, 2 * np.pi, 200001)
    pts = _wheel_points(prof, wpose, phi)
    i = int(np.argmin(np.sum((pts - pc) ** 2, axis=1)))
    h = phi[1] - phi[0]
    s5 = _wheel_points(prof, wpose, phi[i] + h * np.arange(-2, 3))
    tan = (s5[0] - 8 * s5[1] + 8 * s5[3] - s5[4]) / (12 * h)  # five-point tangent (Eq. public_pressure_tangent)
    t = tan / np.linalg.norm(tan)
    n = np.array([-t[1], t[0]]) * np.sign(np.dot([-t[1], t[0]], nrm))
    p0 = pts[i]
    span = 4 * (np.max(np.abs(x)) + 1e-6)
    dphi = span / np.linalg.norm(tan)
    ph = np.linspace(phi[i] - dphi, phi[i] + dphi, 4001)
    w = _wheel_points(prof, wpose, ph) - p0
    ws, wn = w @ t, w @ n
    order = np.argsort(ws)
    wheel = np.interp(x, ws[order], wn[order])
    rp = mesh.pin_radius if mesh.pin_radius is not None else prof.pin_radius
    c = pin_centres(prof)[pin] - p0
    cs, cn = c @ t, c @ n
    # mating-circle branch: the side of the pin facing the wheel (towards -cn direction)
    pinw = cn - np.sign(cn) * np.sqrt(np.maximum(rp ** 2 - (x - cs) ** 2, 0.0))
    g = np.sign(cn) * (pinw - wheel)
    return g - g.min(), float(obs[0])
