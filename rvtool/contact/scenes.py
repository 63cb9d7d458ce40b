"""Small reproducible contact scenes used by the verification tests, the
contact-element benchmark and the history case (not reducer models)."""
import numpy as np

from .circle_set import GROUND, CircleContact, CircleContactSet, FrictionLaw, FrictionModel, NormalLaw


def _local(pose, x):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    d = np.asarray(x, float) - pose[:2]
    return (c * d[0] + s * d[1], -s * d[0] + c * d[1])


def random_pair_scene(rng, n_bodies, n_contacts, *, overlap=2e-5, friction=True, name="random"):
    """Random planar poses/velocities and a set of slightly compressed circle contacts.

    Returns (contact_set, poses (nb, 3), velocities (nb, 3)). Contacts cycle
    through external/internal geometry, the three named laws and the three
    friction models, and about one in six is attached to the ground.
    """
    poses = np.column_stack([rng.normal(0, 1e-3, n_bodies), rng.normal(0, 1e-3, n_bodies),
                             rng.normal(0, 0.3, n_bodies)])
    vels = np.column_stack([rng.normal(0, 0.05, n_bodies), rng.normal(0, 0.05, n_bodies),
                            rng.normal(0, 2.0, n_bodies)])
    ground = np.zeros(3)
    contacts = []
    laws = ("point", "line", "pin")
    models = (FrictionModel.NONE, FrictionModel.REGULARIZED, FrictionModel.ANCHOR) if friction else (FrictionModel.NONE,)
    for i in range(n_contacts):
        a = int(rng.integers(n_bodies))
        b = GROUND if (i % 6 == 5 or n_bodies == 1) else int((a + 1 + rng.integers(n_bodies - 1)) % n_bodies)
        internal = bool(i % 2)
        ra = 3e-3
        rb = 50e-3 if internal else 4e-3
        target = rng.normal(0, 0.02, 2)
        u = rng.normal(size=2)
        u /= np.linalg.norm(u)
        if internal:
            cb, ca = target, target + u * (rb - ra + overlap)
        else:
            ca, cb = target, target + u * (ra + rb - overlap)
        pa = poses[a]
        pb = ground if b == GROUND else poses[b]
        law = laws[i % 3]
        k = {"point": 1e10, "line": 2e8, "pin": 1e9}[law]
        model = models[i % len(models)]
        contacts.append(CircleContact(
            body_a=a, body_b=b, centre_a=_local(pa, ca), centre_b=_local(pb, cb), radius_a=ra, radius_b=rb,
            internal=internal, normal=NormalLaw(law=law, stiffness=k, damping=50.0, ramp_depth=1e-5),
            friction=FrictionLaw(model=model, mu_kinetic=0.1, mu_static=0.15, stribeck_speed=1e-2,
                                 regularization_speed=1e-3, tangential_stiffness=1e8 if model == FrictionModel.ANCHOR else 0.0)))
    return CircleContactSet(name=name, n_bodies=n_bodies, contacts=tuple(contacts)), poses, vels
