"""Several structures behind one merged contact element (issue 32: a spatial body with the ported housing).

:class:`~exudyn_user_elements.merged_element.MergedContactElement` spans the rigid bodies' coordinates and the
coordinates of one ``structure``. A model whose families act on two -- the reduced housing's eta
(:class:`~exudyn_user_elements.reduced_structure.ReducedStructure`, the ring pins on its port bodies) and the
retained out-of-plane coordinates (:class:`~exudyn_user_elements.out_of_plane.RetainedTilt`, the spatial
carrier's main bearing) -- hands the element a :class:`StackedStructure`: their coordinates one after the
other (each member's own Exudyn node, in order), and each family's ports on one member as
:class:`StackedPorts`, its port map P padded with zeros over the other members' coordinates (u = P eta reads
only its own member's block). Nothing else changes: a family's evaluation, contraction and tangent are the
port mechanism of :mod:`exudyn_user_elements.contact_element` with the padded map.
"""
import numpy as np

from rvtool.errors import RvtoolInputError


class StackedPorts:
    """The ports ``ports`` (P (3 n_virtual, n_member)) of one member of ``stack`` as ports on the whole stack:
    P padded with zeros to (3 n_virtual, stack.n) at the member's offset."""

    state_dependent = False

    def __init__(self, ports, stack, offset):
        self.inner, self.structure = ports, stack
        self.n_virtual, self.n_eta = int(ports.n_virtual), int(stack.n)
        P = np.asarray(ports.P, float)
        self.P = np.zeros((P.shape[0], stack.n))
        self.P[:, offset:offset + P.shape[1]] = P


class StackedStructure:
    """The coordinates of ``structures`` (each with ``node`` and ``n``), one after the other."""

    def __init__(self, structures):
        self.structures = tuple(structures)
        if len(self.structures) < 2:
            raise RvtoolInputError(f"a stacked structure needs at least two members; got {len(self.structures)}")
        sizes = [int(s.n) for s in self.structures]
        self.offsets = tuple(int(o) for o in np.cumsum([0] + sizes[:-1]))
        self.n = int(sum(sizes))
        self.nodes = [s.node for s in self.structures]

    def ports(self, ports):
        """:class:`StackedPorts` of ``ports`` (ports on one member: ``ports.structure`` is that member)."""
        for s, off in zip(self.structures, self.offsets):
            if ports.structure is s:
                return StackedPorts(ports, self, off)
        raise RvtoolInputError("ports must act on one of the stacked structures")
