"""Contact-element layout of a topology builder (issue 19, "one contact element per Exudyn system").

``"merged"``: every contact family of the reducer in one
:class:`~exudyn_user_elements.merged_element.MergedContactElement` (one force and one
Jacobian callback per Newton evaluation, launchable families summed on the device, the
per-attempt drive and load set by the host); ``"per_family"``: one
:class:`~exudyn_user_elements.contact_element.ContactElement` per family, each with its own
callbacks (the former layout, kept selectable). Same families, ids, rows and physics in both;
only the order in which the families' generalized forces are summed differs (round-off).
The cycloid, RV and small-tooth-difference builders take the layout from here.
"""
import os

from ..errors import RvtoolInputError

CONTACT_ELEMENTS = ("per_family", "merged")
"""Valid contact-element layouts."""

ENVIRONMENT_VARIABLE = "RVTOOL_CONTACT_ELEMENT"


def contact_element_mode(value=None):
    """The contact-element layout of a builder: ``value``, else the environment variable
    ``RVTOOL_CONTACT_ELEMENT``, else ``"merged"`` (checked against CONTACT_ELEMENTS). The merged
    layout is the default since it reproduced every quick case's figures (README, "One contact
    element per Exudyn system" and "One contact element for the RV and STD builders");
    ``"per_family"`` stays selectable."""
    mode = value if value is not None else os.environ.get(ENVIRONMENT_VARIABLE, "merged")
    if mode not in CONTACT_ELEMENTS:
        raise RvtoolInputError(f"contact_element = {mode!r}; valid choices are {list(CONTACT_ELEMENTS)} "
                               f"(argument of build or environment variable {ENVIRONMENT_VARIABLE})")
    return mode


class ContactElements:
    """Adds the contact families of one Exudyn system in the chosen layout.

    mbs: the MainSystem; nodes: the rigid-body node numbers every family is evaluated on (body
    order); mode: a layout of CONTACT_ELEMENTS or None (:func:`contact_element_mode`);
    structure: the :class:`~exudyn_user_elements.reduced_structure.ReducedStructure` that
    ported families act on, or None. ``host`` is the merged element (None per family); calling
    the object adds a family and returns its element (``ContactElement`` or
    ``HostedContactElement``, the same interface).
    """

    def __init__(self, mbs, nodes, mode=None, *, structure=None):
        self.mode = contact_element_mode(mode)
        self.mbs = mbs
        self.nodes = [int(n) for n in nodes]
        self.host = None
        if self.mode == "merged":
            from exudyn_user_elements.merged_element import MergedContactElement
            self.host = MergedContactElement(mbs, self.nodes, structure=structure)

    def __call__(self, contact_set, **kw):
        if self.host is not None:
            return self.host.add(contact_set, **kw)
        from exudyn_user_elements.contact_element import ContactElement
        return ContactElement(self.mbs, self.nodes, contact_set, **kw)
