"""Small reproducible contact scenes used by the verification tests, the
contact-element benchmark and the history case (not reducer models)."""
import numpy as np

from rvtool.contact.circle_set import GROUND, CircleContact, CircleContactSet, FrictionLaw, FrictionModel, NormalLaw


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


def block_on_belt(*, normal_load=100.0, mu=0.3, tangential_stiffness=1e6, spring=1e5, spring_damping=60.0,
                  amplitude=2e-3, frequency=2.0, block_mass=1.0, backend="warp", precision="float64"):
    """A block pressed onto a belt that oscillates, with anchor friction: an
    imposed stick--slip cycle.

    The block (planar rigid body, rotation locked) carries a circle of radius
    5 mm pressed with ``normal_load`` [N] onto the belt, modelled as a circle of
    radius 1 m (a nearly flat surface) on a body whose x follows
    ``amplitude`` sin(2 pi ``frequency`` t) [m]. A spring [N/m] with damper
    [N s/m] ties the block to the ground in x. The friction limit mu F_N is
    reached on every half cycle, so the contact alternates between stick and slip.

    Returns (SystemContainer, mbs, ContactElement).
    """
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate, MarkerNodeCoordinate,
                                      NodeRigidBody2D, NodePointGround, ObjectRigidBody2D)

    from .contact_element import ContactElement

    r_block, r_belt, k_point = 5e-3, 1.0, 1e10
    delta0 = (normal_load / k_point) ** (2.0 / 3.0)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nb = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, r_block - delta0, 0.0]))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=nb, mass=block_mass, inertia=1e-4))
    nbelt = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=nbelt, mass=10.0, inertia=1.0))
    ng = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
    mk = [mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nb, coordinate=i)) for i in range(3)]
    mbelt = [mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nbelt, coordinate=i)) for i in range(3)]
    w = 2 * np.pi * frequency

    def belt_x(mbs_, t, itemNumber, lOffset):
        return amplitude * np.sin(w * t)

    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mbelt[0]], offsetUserFunction=belt_x))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mbelt[1]]))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mbelt[2]]))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mk[2]]))
    mbs.AddObject(CoordinateSpringDamper(markerNumbers=[mg, mk[0]], stiffness=spring, damping=spring_damping))
    mbs.AddLoad(LoadCoordinate(markerNumber=mk[1], load=-normal_load))
    cset = CircleContactSet(name="belt", n_bodies=2, contacts=(CircleContact(
        body_a=0, body_b=1, centre_a=(0.0, 0.0), centre_b=(0.0, -r_belt), radius_a=r_block, radius_b=r_belt,
        normal=NormalLaw(law="point", stiffness=k_point, damping=200.0, ramp_depth=1e-6),
        friction=FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=mu, tangential_stiffness=tangential_stiffness),
        name="belt/block"),))
    el = ContactElement(mbs, [nb, nbelt], cset, backend=backend, precision=precision)
    mbs.Assemble()
    return SC, mbs, el


def jenkins_element(*, normal_load=100.0, mu=0.3, tangential_stiffness=1e6, spring=1e5, amplitude=1e-3,
                    frequency=1.0, dwell=0.0, block_mass=0.05, drive_mass=0.01, surface_radius=100.0,
                    normal_damping=200.0, backend="warp", precision="float64"):
    """A Jenkins element: a spring in series with a Coulomb slider, driven
    through a prescribed displacement.

    A drive coordinate rests for ``dwell`` [s] and then follows
    x_d(t) = ``amplitude`` sin(2 pi ``frequency`` (t - ``dwell``)) [m] (a
    ``CoordinateConstraint`` with an offset function: the prescribed motion
    whose reaction does the drive work). Anchors are committed at accepted
    steps only, so the first step from t_0 carries no tangential force; a dwell
    of one step lets the anchor form at rest. A spring of stiffness
    ``spring`` [N/m] ties it to a block (planar rigid body, rotation locked,
    mass ``block_mass`` [kg]) that is pressed with ``normal_load`` [N] onto
    the ground. The block--ground contact is a circle of radius 5 mm on a
    ground circle of ``surface_radius`` [m] (nearly flat) with the anchor
    friction model (coefficient ``mu``, tangential stiffness
    ``tangential_stiffness`` [N/m]): the slider of friction force
    F_c = mu F_N, regularized in stick by the anchor spring k_t in series
    with the spring.

    Returns (SystemContainer, mbs, ContactElement, items) with items the
    object/node numbers {"drive_node", "block_node", "drive", "spring", "load"}.
    """
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate,
                                      MarkerNodeCoordinate, Node1D, NodePointGround, NodeRigidBody2D, ObjectMass1D,
                                      ObjectRigidBody2D)

    from .contact_element import ContactElement

    r_block, k_point = 5e-3, 1e10
    delta0 = (normal_load / k_point) ** (2.0 / 3.0)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ng = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
    nd = mbs.AddNode(Node1D(referenceCoordinates=[0.0]))
    mbs.AddObject(ObjectMass1D(nodeNumber=nd, mass=drive_mass))
    md = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nd, coordinate=0))
    nb = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, r_block - delta0, 0.0]))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=nb, mass=block_mass, inertia=1e-6))
    mk = [mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nb, coordinate=i)) for i in range(3)]
    w = 2 * np.pi * frequency

    def drive_x(mbs_, t, itemNumber, lOffset):
        return amplitude * np.sin(w * (t - dwell)) if t > dwell else 0.0

    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, md], offsetUserFunction=drive_x))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mk[2]]))
    spring_obj = mbs.AddObject(CoordinateSpringDamper(markerNumbers=[md, mk[0]], stiffness=spring))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=mk[1], load=-normal_load))
    cset = CircleContactSet(name="slider", n_bodies=1, contacts=(CircleContact(
        body_a=0, body_b=GROUND, centre_a=(0.0, 0.0), centre_b=(0.0, -surface_radius), radius_a=r_block,
        radius_b=surface_radius, normal=NormalLaw(law="point", stiffness=k_point, damping=normal_damping,
                                                  ramp_depth=1e-6),
        friction=FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=mu, tangential_stiffness=tangential_stiffness),
        name="slider/block"),))
    el = ContactElement(mbs, [nb], cset, backend=backend, precision=precision)
    mbs.Assemble()
    return SC, mbs, el, {"drive_node": nd, "block_node": nb, "drive": drive, "spring": spring_obj, "load": load}
