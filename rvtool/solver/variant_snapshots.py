"""Snapshots of many manufacturing variants of one cycloid design without a model build per variant.

:func:`rvtool.solver.model_snapshot.build_snapshot` builds a variant's whole model (Exudyn bodies,
constraints, every contact set) to read its rows. A :class:`rvtool.variants.Variant` of a cycloid
design changes the eccentricity, the pin clearance, the pin centres and radius, the eccentric
bearing's clearance and the profile modifications only (:meth:`Variant.apply`), which reach the
device row Newton through four members of the snapshot: the cycloid pin set (rows and profile
tables), the lumped bearings' circle contacts, the bodies' reference poses and the kinematics.
:func:`cycloid_variant_snapshots` builds the nominal design's snapshot once and writes those four
per variant with the builder's own pieces (:func:`rvtool.assembly.cycloid.pin_meshes`,
:func:`~rvtool.assembly.cycloid.lumped_bearing_contacts`, :class:`~rvtool.assembly.cycloid.CycloidKinematics`,
the journal centres of :func:`~rvtool.assembly.cycloid.add_bodies`) from the variant's design made
without loading it again (:func:`light_design`), the pin set on shared profile
tables (:func:`rvtool.contact.cycloid_set.shared_profile_tables`): equal to
``build_snapshot(variant design, build_kw, shared_tables=True)`` attribute for attribute
(tests/test_variant_snapshots.py). The rest (output pins, locks, springs, drive and load) is the
nominal snapshot's. A variant's build is then its profile tables (its profile is drawn) and a few
small arrays.

Where the builder would read a variant's fields in other places (elastic or ported housings and
pins, flexible or spatial wheels, rolling-element bearings, bearing friction, rigid supports),
:func:`patchable` says why and :func:`cycloid_variant_snapshots` builds each variant in full.
"""
import copy

import numpy as np

from ..errors import RvtoolInputError
from .model_snapshot import ModelSnapshot, build_snapshot

#: the contact elements of a patchable snapshot, by name and set type name (module docstring)
ELEMENTS = (("pins", "CycloidPinSet"), ("output_pins", "OutputPinEvaluator"), ("bearings", "ContactSetEvaluator"))


def patchable(design, build_kw=None):
    """Reasons why the variants of ``design`` built with ``build_kw`` cannot be written into the nominal
    snapshot (empty: they can; see the module docstring)."""
    from ..assembly.cycloid import pin_station_compliance
    from ..assembly.spec import CycloidDesign
    from ..model import Family
    kw = dict(build_kw or {})
    if not isinstance(design, CycloidDesign):
        return [f"{type(design).__name__}: only cycloid designs (their Variant) are written into a nominal snapshot"]
    out = []
    if kw.get("bearing_model", "lumped") != "lumped":
        out.append(f"bearing_model = {kw['bearing_model']!r} (valid: 'lumped')")
    if kw.get("rigid_supports", False):
        out.append("rigid_supports = True (its journal locks follow the eccentricity)")
    if kw.get("precision", "float64") != "float64":
        out.append(f"precision = {kw['precision']!r} (valid: 'float64')")
    d = design
    if d.housing.model != "rigid":
        out.append(f"housing.model = {d.housing.model!r} (valid: 'rigid')")
    if d.wheels.dynamics.flexible or d.wheels.body != "rigid":
        out.append("flexible or ported wheels (valid: rigid)")
    if d.bodies.spatial_flange or d.bodies.spatial_wheels:
        out.append("spatial flange or wheels (valid: planar)")
    if d.bearing_friction.model != "none":
        out.append(f"bearing_friction.model = {d.bearing_friction.model!r} (valid: 'none')")
    if d.pins.groove != "rigid":
        out.append(f"pins.groove = {d.pins.groove!r} (valid: 'rigid')")
    for fam in (Family.PINS, Family.OUTPUT_PINS):
        if pin_station_compliance(d, fam) is not None:
            out.append(f"elastic {fam.value} (valid: rigid pin supports)")
    return out


_NOMINAL = {}
"""(design, build options) -> [nominal snapshot, whether its elements are :data:`ELEMENTS`, whether
:func:`light_design` gives the loaded variant designs (None: not checked yet)], per process."""


def _nominal(design, kw):
    key = (design, tuple(sorted((k, repr(v)) for k, v in kw.items())))
    try:
        hit = _NOMINAL.get(key)
    except TypeError:                     # an unhashable design: no nominal kept
        return [None, False, None]
    if hit is None:
        snap = build_snapshot(design, kw, shared_tables=True)
        els = snap.contact_elements()
        ok = (snap.row_extension is None and len(els) == len(ELEMENTS)
              and all(e.evaluator.name == n and type(e.evaluator).__name__ == t for e, (n, t) in zip(els, ELEMENTS)))
        if len(_NOMINAL) >= 8:
            _NOMINAL.pop(next(iter(_NOMINAL)))
        hit = _NOMINAL[key] = [snap, ok, None]
    return hit


def _pin_set(nominal, d, backend, defer=False):
    """The cycloid pin set of variant design ``d`` as the builder makes it (its meshes, rows and shared
    profile tables; ``defer``: the tables not computed, :func:`rvtool.contact.cycloid_set.shared_profile_tables`)
    and as a snapshot holds it (no device objects, the build's ``backend``)."""
    from ..assembly.cycloid import pin_meshes
    from ..contact.cycloid_set import CycloidPinSet, shared_profile_tables
    from .model_snapshot import snapshot_set
    _, meshes = pin_meshes(d)
    with shared_profile_tables(defer=defer):
        s = CycloidPinSet(meshes, nominal.n_bodies, samples_per_tooth=d.wheels.samples_per_tooth, backend="numpy",
                          precision=nominal.precision, name=nominal.name, search=d.wheels.search)
    return snapshot_set(s, backend)


def _bearings(nominal, d):
    """The lumped bearings' evaluator of variant design ``d``: the nominal one with the variant's
    contacts and their packed rows (the same names, bodies and laws)."""
    from ..assembly.cycloid import lumped_bearing_contacts
    from ..contact.circle_set import CircleContactSet
    out = object.__new__(type(nominal))
    out.__dict__.update(vars(nominal))
    out.set = CircleContactSet(name=nominal.set.name, n_bodies=nominal.set.n_bodies,
                               contacts=tuple(lumped_bearing_contacts(d)))
    fp, ip = out.set.packed()
    if not np.array_equal(ip, nominal.iparams):
        raise RvtoolInputError("a variant's lumped bearings have other bodies or kinds than the nominal design's")
    out.fparams, out.iparams = fp, nominal.iparams.copy()
    out.history = copy.deepcopy(nominal.history)
    return out


def light_design(design, variant):
    """The design of ``variant`` of cycloid ``design`` with the fields :meth:`Variant.apply` writes set by
    ``dataclasses.replace`` (each section validated) and its file-form data (``source``: what ``apply``
    would load, :func:`rvtool.assembly.spec.replaced_source`) without loading it again (~3 ms a variant):
    equal to ``variant.apply(design)``, source included, where no link of the file form follows those fields
    (checked once per design by :func:`cycloid_variant_snapshots`)."""
    import dataclasses
    from ..assembly.spec import replaced_source
    sections = variant.sections(design)      # checked as apply checks them (its errors, by name)
    w, prof, pins = design.wheels, design.profile, design.pins
    e = prof.generating_eccentricity + variant.eccentricity_error
    changes = {"wheels": dataclasses.replace(w, eccentricity=e, clearance=w.clearance + variant.pin_clearance),
               "profile": dataclasses.replace(prof, equidistant_mod=prof.equidistant_mod + variant.equidistant_mod,
                                              offset_mod=prof.offset_mod + variant.offset_mod)}
    if variant.bearing_clearance is not None:
        changes["eccentric_bearing"] = dataclasses.replace(design.eccentric_bearing,
                                                           radial_clearance=variant.bearing_clearance)
    p = {}
    if variant.pin_centre_errors is not None:
        p["centre_errors"] = tuple(map(tuple, np.asarray(variant.pin_centre_errors, float)))
    if variant.pin_radius_error != 0.0:
        p["radius_error"] = pins.radius_error + variant.pin_radius_error
    if p:
        changes["pins"] = dataclasses.replace(pins, **p)
    return dataclasses.replace(design, **changes, source=replaced_source(design, **sections))


def _variant_snapshot(nominal, d, defer=False):
    """The snapshot of variant design ``d`` written into ``nominal`` (module docstring)."""
    from ..assembly.cycloid import CycloidKinematics
    from ..geometry.eccentric import journal_centre
    from .model_snapshot import SnapshotElement
    out = object.__new__(ModelSnapshot)
    out.__dict__.update(vars(nominal))
    out.design = d
    out.build_kw = dict(nominal.build_kw)
    out.journal_locks, out.reg_springs = list(nominal.journal_locks), list(nominal.reg_springs)
    out.held_coordinates = list(nominal.held_coordinates)
    out.structures = dict(nominal.structures)
    out._model = None
    reference = np.array(nominal.reference, float)
    for k in range(d.n_wheels):
        reference[1 + k, :2] = journal_centre(d.wheels.eccentricity, d.wheels.phases[k])     # add_bodies' poses
    out.reference = reference
    out.kinematics = CycloidKinematics(d)
    pins, op, brg = (e for e in nominal.contact_elements())
    op_set = object.__new__(type(op.evaluator))
    op_set.__dict__.update(vars(op.evaluator))
    op_set.history = copy.deepcopy(op.evaluator.history)
    backend = nominal.build_kw.get("backend", "warp")
    out._elements = (SnapshotElement(_pin_set(pins.evaluator, d, backend, defer), pins.ids), SnapshotElement(op_set, op.ids),
                     SnapshotElement(_bearings(brg.evaluator, d), brg.ids))
    return out


def cycloid_variant_snapshots(design, variants, build_kw=None, *, defer_tables=False):
    """[:class:`~rvtool.solver.model_snapshot.ModelSnapshot`] of ``variants`` (:class:`rvtool.variants.Variant`)
    of cycloid ``design`` built with ``build_kw``: the nominal snapshot with each variant's pin set,
    bearings, reference poses and kinematics written in (module docstring), or, where
    :func:`patchable` names a reason, each variant built in full (``build_snapshot(...,
    shared_tables=True)``). Equal to the full builds' snapshots either way. defer_tables: the written-in
    pin sets' profile tables are not computed here (:func:`rvtool.contact.cycloid_set.shared_profile_tables`
    ``defer``; pickled as their profiles, computed by the receiver, e.g. on its Warp device by
    :func:`rvtool.contact.cycloid_set.compute_profile_tables`); default off."""
    variants = list(variants)
    kw = dict(build_kw or {})
    entry = [None, False, None] if patchable(design, kw) else _nominal(design, kw)
    if not entry[1] or not variants:
        return [build_snapshot(v.apply(design), kw, shared_tables=True) for v in variants]
    if entry[2] is None:                  # once per design: the light design equals the loaded one
        light, loaded = light_design(design, variants[0]), variants[0].apply(design)
        try:
            entry[2] = bool(light == loaded and light.source == loaded.source)
        except (TypeError, ValueError):   # members that do not compare (arrays): load every variant
            entry[2] = False
    return [_variant_snapshot(entry[0], light_design(design, v) if entry[2] else v.apply(design), defer_tables)
            for v in variants]


__all__ = ["ELEMENTS", "cycloid_variant_snapshots", "light_design", "patchable"]
