"""Specification of a set of circle--circle contacts between planar rigid bodies.

A contact set is plain data (frozen dataclasses); it is packed into the
parameter arrays of :mod:`warp_contacts.circle_pairs` once, validated on
construction with errors that name the parameter and its valid range.
"""
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from warp_contacts import circle_pairs_ref as ref

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative, check_positive, check_range

GROUND = -1
"""Body index of the fixed ground in a contact specification."""

#: Exponents of the named elastic laws of Eq. (normal_force): point (Hertz) contact,
#: linearized line contact and the output-pin law.
LAW_EXPONENTS = {"point": 1.5, "line": 1.0, "pin": 10.0 / 9.0}


class FrictionModel(IntEnum):
    """Tangential law: none, regularized velocity law (Eq. (friction)) or anchor stick--slip."""
    NONE = ref.FRICTION_NONE
    REGULARIZED = ref.FRICTION_REGULARIZED
    ANCHOR = ref.FRICTION_ANCHOR


@dataclass(frozen=True, kw_only=True)
class NormalLaw:
    """Elastic power law with damping ramp, Eq. (normal_force).

    law: "point" (p = 3/2), "line" (p = 1), "pin" (p = 10/9) or "power" with ``exponent``.
    stiffness: k [N m^-p]. damping: c [N s/m]. ramp_depth: delta_r [m], the
    indentation over which damping is ramped in.
    """
    law: str = "point"
    stiffness: float
    exponent: float | None = None
    damping: float = 0.0
    ramp_depth: float = 1e-6

    def __post_init__(self):
        if self.law not in (*LAW_EXPONENTS, "power"):
            raise RvtoolInputError(f"law = {self.law!r} is not a known contact law; valid: {sorted(LAW_EXPONENTS) + ['power']}")
        if self.law == "power" and self.exponent is None:
            raise RvtoolInputError("exponent must be given for law = 'power' (valid range [1, inf))")
        check_nonnegative("stiffness", self.stiffness)
        check_range("exponent", self.p, 1.0)
        check_nonnegative("damping", self.damping)
        check_positive("ramp_depth", self.ramp_depth)

    @property
    def p(self):
        return LAW_EXPONENTS[self.law] if self.law != "power" else float(self.exponent)


@dataclass(frozen=True, kw_only=True)
class FrictionLaw:
    """Tangential contact law.

    model: :class:`FrictionModel`. mu_kinetic, mu_static: coefficients [-]
    (mu_static >= mu_kinetic). stribeck_speed: v_s [m/s].
    regularization_speed: v_reg [m/s] of the tanh regularization.
    tangential_stiffness: k_t [N/m] of the anchor model.
    """
    model: FrictionModel = FrictionModel.NONE
    mu_kinetic: float = 0.0
    mu_static: float | None = None
    stribeck_speed: float = 1e-2
    regularization_speed: float = 1e-4
    tangential_stiffness: float = 0.0

    def __post_init__(self):
        if not isinstance(self.model, FrictionModel):
            try:
                object.__setattr__(self, "model", FrictionModel(self.model))
            except ValueError:
                raise RvtoolInputError(f"model = {self.model!r} is not a friction model; valid: {[m.name for m in FrictionModel]}") from None
        check_nonnegative("mu_kinetic", self.mu_kinetic)
        check_range("mu_static", self.mu_s, self.mu_kinetic)
        check_positive("stribeck_speed", self.stribeck_speed)
        check_positive("regularization_speed", self.regularization_speed)
        check_nonnegative("tangential_stiffness", self.tangential_stiffness)
        if self.model == FrictionModel.ANCHOR and self.tangential_stiffness <= 0:
            raise RvtoolInputError("tangential_stiffness must be > 0 for the anchor friction model "
                                   f"(got {self.tangential_stiffness}; valid range (0, inf) N/m)")

    @property
    def mu_s(self):
        return self.mu_kinetic if self.mu_static is None else self.mu_static


@dataclass(frozen=True, kw_only=True)
class CircleContact:
    """One circle--circle contact.

    body_a, body_b: body indices within the set's body list (``GROUND`` = -1).
    centre_a, centre_b: circle centres in body coordinates [m] (ground: global).
    radius_a: r_A [m]; radius_b: r_B, or the enclosing radius R_B for ``internal`` [m].
    internal: circle A inside circle B (Section "Contact laws, signed clearance").
    """
    body_a: int
    body_b: int
    centre_a: tuple
    centre_b: tuple
    radius_a: float
    radius_b: float
    internal: bool = False
    normal: NormalLaw
    friction: FrictionLaw = field(default_factory=FrictionLaw)
    name: str = ""

    def __post_init__(self):
        for nm in ("centre_a", "centre_b"):
            v = np.asarray(getattr(self, nm), dtype=float)
            if v.shape != (2,):
                raise RvtoolInputError(f"{nm} must have 2 components [m]; got shape {v.shape}")
            check_finite(nm, v)
        check_positive("radius_a", self.radius_a)
        check_positive("radius_b", self.radius_b)
        if self.internal and self.radius_b <= self.radius_a:
            raise RvtoolInputError(f"radius_b = {self.radius_b} must exceed radius_a = {self.radius_a} for internal contact "
                                   "(valid range (radius_a, inf) m)")
        if self.body_a == self.body_b:
            raise RvtoolInputError(f"body_a and body_b must differ; both are {self.body_a}")


@dataclass(frozen=True)
class CircleContactSet:
    """A named set of circle contacts over ``n_bodies`` planar rigid bodies.

    Evaluated in one kernel launch; the packed arrays are built once.
    """
    name: str
    n_bodies: int
    contacts: tuple

    def __post_init__(self):
        if not isinstance(self.n_bodies, (int, np.integer)) or self.n_bodies < 1:
            raise RvtoolInputError(f"n_bodies = {self.n_bodies!r} is outside the valid range [1, inf)")
        if len(self.contacts) == 0:
            raise RvtoolInputError("contacts must hold at least one CircleContact (got 0)")
        for i, c in enumerate(self.contacts):
            if not isinstance(c, CircleContact):
                raise RvtoolInputError(f"contacts[{i}] must be a CircleContact; got {type(c).__name__}")
            for nm in ("body_a", "body_b"):
                b = getattr(c, nm)
                if not (b == GROUND or 0 <= b < self.n_bodies):
                    raise RvtoolInputError(f"contacts[{i}].{nm} = {b} is outside the valid range "
                                           f"[0, {self.n_bodies - 1}] or GROUND (-1)")

    @property
    def ids(self):
        return tuple(c.name or f"{self.name}/{i}" for i, c in enumerate(self.contacts))

    def packed(self):
        """Return (fparams (N, 15), iparams (N, 4)) in the layout of circle_pairs_ref."""
        N = len(self.contacts)
        fp = np.zeros((N, ref.N_FLOAT_PARAMS))
        ip = np.zeros((N, ref.N_INT_PARAMS), dtype=np.int32)
        g = self.n_bodies  # ground row of the pose array
        for i, c in enumerate(self.contacts):
            fp[i, ref.P_XI_A:ref.P_XI_A + 2] = c.centre_a
            fp[i, ref.P_XI_B:ref.P_XI_B + 2] = c.centre_b
            fp[i, ref.P_RA], fp[i, ref.P_RB] = c.radius_a, c.radius_b
            fp[i, ref.P_K], fp[i, ref.P_P] = c.normal.stiffness, c.normal.p
            fp[i, ref.P_C], fp[i, ref.P_DR] = c.normal.damping, c.normal.ramp_depth
            f = c.friction
            fp[i, ref.P_MUK], fp[i, ref.P_MUS] = f.mu_kinetic, f.mu_s
            fp[i, ref.P_VS], fp[i, ref.P_VREG], fp[i, ref.P_KT] = f.stribeck_speed, f.regularization_speed, f.tangential_stiffness
            ip[i, ref.I_BODY_A] = g if c.body_a == GROUND else c.body_a
            ip[i, ref.I_BODY_B] = g if c.body_b == GROUND else c.body_b
            ip[i, ref.I_INTERNAL], ip[i, ref.I_FRICTION] = int(c.internal), int(f.model)
        return fp, ip
