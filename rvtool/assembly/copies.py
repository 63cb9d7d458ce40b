"""Contact definitions of one copy of a cycloid reducer at a body offset: the pieces that the
batched Exudyn system (:mod:`rvtool.batched.assembly`) and the device copies
(:mod:`rvtool.solver.device_copies`) assemble, taken from the builder so a copy is
``build(..., bearing_model="lumped")`` by construction."""
from ..errors import RvtoolInputError
from .cycloid import lumped_bearing_contacts, pin_meshes


def copy_contacts(design, offset):
    """Contact definitions of one copy whose bodies start at global index ``offset``
    (shaft ``offset``, wheels ``offset + 1..n``, flange ``offset + n + 1``): the builder's own
    :func:`~rvtool.assembly.cycloid.pin_meshes`, the design's output-pin mechanism
    and :func:`~rvtool.assembly.cycloid.lumped_bearing_contacts` at that offset, so a copy is
    ``build(..., bearing_model="lumped")`` by construction.

    Returns (wheel meshes, bearing circle contacts, output-pin (fparams, iparams, stations)).
    """
    for sec in ("pins", "output_pins"):
        if getattr(design, sec).support.elastic:
            raise RvtoolInputError(f"{sec}.support.model = {getattr(design, sec).support.model.value!r}: elastic pins "
                                   "are closed per pin in the sequential model only (rvtool.contact.pin_closure); "
                                   "valid for batched copies: 'rigid'")
    prefix = f"copy{offset}/"
    nw = design.n_wheels
    _, meshes = pin_meshes(design, offset=offset, prefix=prefix)
    mech = design.output_pins
    fp, ip = mech.packed(offset + nw + 1, tuple(range(offset + 1, offset + nw + 1)))
    return meshes, lumped_bearing_contacts(design, offset=offset, prefix=prefix), (fp, ip, mech.stations)
