"""Picklable snapshots of built reducer models for the device row Newton: what
:class:`rvtool.solver.device_rows.DeviceRowNewton` and :func:`rvtool.solver.replica.copy_families`
read from a model (bodies, reference poses, kinematics, locks, springs, drive and load, and the
contact sets' built rows), without its Exudyn system or its Warp kernels.

A Monte Carlo study builds its variant models in worker processes and sends their snapshots to
the process that runs the device (:func:`rvtool.batched.device_rows_variants.prepare_variant_models`):
building a variant is serial Python (~20-100 ms: profile tables, packing rows, the Exudyn items),
copying its rows onto the device is not. A snapshot's contact sets are copies of the built sets
without their kernels: the copiers read their rows (:meth:`CycloidPinSet.concatenated` and the
like), never evaluate them. Where the device hands a point or copy over to Exudyn, the model is
built from the snapshot's design in this process (:func:`real_model`, once per snapshot).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..model.reducer import COORDINATES, body_index

#: attributes of a contact set that hold device objects (Warp kernels, staged launches) or what only
#: an evaluation reads (its assembler, pose buffers): not copied (None in the snapshot)
DEVICE_ATTRIBUTES = ("_kernel", "_staged", "_device_rows", "_slices", "_scatter", "assembler", "_pose", "_vel",
                     "_mounting_sum")


@dataclass(frozen=True)
class SnapshotElement:
    """A contact element of a snapshot: its set without device objects, and its observation ids."""
    evaluator: object
    ids: tuple


def _set_without_device(s, memo=None, backend=None):
    """A copy of contact set ``s`` without its device objects (its rows, members and tables as built);
    a series closure's inner set and a stacked set's parts likewise (``memo``: id -> copy, so a set
    reached twice is copied once). backend: the backend a set built with the NumPy backend carries
    in the copy (:func:`build_snapshot`; None: as built)."""
    memo = {} if memo is None else memo
    if id(s) in memo:
        return memo[id(s)]
    if getattr(s, "_slices", None) is not None:
        raise RvtoolInputError(f"contact set {s.name!r} has influence-coefficient rows; a snapshot copies laminae "
                               "rows only (valid: slices = 'laminae')")
    out = object.__new__(type(s))
    out.__dict__.update({k: v for k, v in vars(s).items() if k not in DEVICE_ATTRIBUTES})
    for k in DEVICE_ATTRIBUTES:
        if k in vars(s):
            out.__dict__[k] = None
    if backend is not None and out.__dict__.get("backend") == "numpy":
        out.__dict__["backend"] = backend
        out.__dict__.setdefault("_kernel", None)      # as a set built with a kernel, dropped (DEVICE_ATTRIBUTES)
    memo[id(s)] = out
    from ..contact.pin_closure import ElasticPinClosure
    from ..contact.stacked import StackedContactSet
    if isinstance(s, ElasticPinClosure):
        out.__dict__["inner"] = _set_without_device(s.inner, memo, backend)
    elif isinstance(s, StackedContactSet):
        out.__dict__["parts"] = tuple(_set_without_device(p, memo, backend) for p in s.parts)
    return out


def snapshot_set(s, backend=None):
    """A copy of contact set ``s`` as a :class:`ModelSnapshot` holds it: without its device objects (see
    :data:`DEVICE_ATTRIBUTES`); a set built with the NumPy backend carries ``backend`` (None: as built)."""
    return _set_without_device(s, None, backend)


class ModelSnapshot:
    """The device row Newton's view of a built model (module docstring): ``design`` and
    ``build_kw`` (to build the model itself where Exudyn takes over), ``body_names``,
    ``reference`` (nb, 3), ``kinematics``, ``journal_locks``, ``reg_springs``,
    ``held_coordinates`` [(body, coordinate)], ``input``, ``output``, ``ratio``, ``structures``
    and the contact elements' sets (:meth:`contact_elements`)."""

    def __init__(self, model, design, build_kw=None, *, backend=None):
        """backend: the backend the copied sets built with the NumPy backend carry (:func:`build_snapshot`)."""
        from .replica import held_coordinates
        self.design, self.build_kw = design, dict(build_kw or {})
        self.body_names = tuple(model.body_names)
        self.reference = np.array(model.reference, float)
        self.kinematics = model.kinematics
        self.journal_locks = list(model.journal_locks)
        self.reg_springs = list(model.reg_springs)
        self.held_coordinates = list(held_coordinates(model))
        self.input, self.output, self.ratio = model.input, model.output, float(model.ratio)
        # the structures by name (their objects hold the Exudyn system); the row Newton's extra unknowns
        # of closures and port bodies (rvtool.solver.row_extension), their sets copied as the elements'
        from .row_extension import snapshot_extension
        self.structures = {k: None for k in model.structures}
        memo = {}
        self._elements = tuple(SnapshotElement(_set_without_device(e.evaluator, memo, backend), tuple(e.ids))
                               for e in model.contact_elements())
        self.row_extension, self.row_extension_reasons = snapshot_extension(
            model, lambda st: _set_without_device(st, memo, backend))
        self._model = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_model"] = None                  # a built model (Exudyn system) stays in its process
        return state

    def contact_elements(self):
        return list(self._elements)

    def body_index(self, body):
        """Index of a body given by name or index (as :meth:`ReducerModel.body_index`)."""
        return body_index(self.body_names, body)

    def reference_value(self, bc):
        """Reference value of a :class:`BodyCoordinate` (as :meth:`ReducerModel.reference_value`)."""
        return float(self.reference[self.body_index(bc.body), COORDINATES.index(bc.coordinate)])

    @property
    def is_built(self):
        """Whether :meth:`model` has built the model in this process."""
        return self._model is not None

    def model(self):
        """The model itself, built from the design in this process (once)."""
        if self._model is None:
            from ..assembly import build
            self._model = build(self.design, **self.build_kw)
        return self._model


def build_snapshot(design, build_kw=None, *, shared_tables=False):
    """The :class:`ModelSnapshot` of ``build(design, **build_kw)``, built without device objects.

    shared_tables: build inside :func:`rvtool.contact.cycloid_set.shared_profile_tables`: the cycloid
    pin sets take one shared table per wheel profile (the nominal design's for every variant that
    draws pin radii, clearances, positions or eccentricities but keeps the profile), so the build
    skips the per-pin-radius table and search window and the pickled snapshot carries the table's key
    instead of its arrays; the device copies then hold one table per distinct profile. The device's
    figures are those of the full tables (the same nearest samples; tests/test_shared_tables.py).

    A snapshot drops every device object of its sets (:data:`DEVICE_ATTRIBUTES`), so a worker that
    builds one for the device need not make them: the sets are built with the NumPy backend (the
    same rows, tables and members: the backend only decides whether a set makes its Warp kernel in
    ``_finish``) and then carry the backend of ``build_kw`` (default "warp"), which the copiers
    (:func:`rvtool.solver.replica.copy_families`) use for the device copies. On RD-40 the Warp
    kernels and arrays are ~2/3 of a variant's build. The snapshot equals the snapshot of the full
    build attribute for attribute (tests/test_model_snapshot.py); ``build_kw`` is kept as given, so
    a model built for an Exudyn fallback (:meth:`ModelSnapshot.model`) is the full one. A build
    whose precision is not float64 (the NumPy backend's only one) is built in full."""
    import contextlib
    from ..assembly import build
    from ..contact.cycloid_set import shared_profile_tables
    kw = dict(build_kw or {})
    backend = kw.get("backend", "warp")
    with shared_profile_tables() if shared_tables else contextlib.nullcontext():
        if kw.get("precision", "float64") != "float64" or backend == "numpy":
            return ModelSnapshot(build(design, **kw), design, kw)
        return ModelSnapshot(build(design, **dict(kw, backend="numpy")), design, kw, backend=backend)


def real_model(model):
    """``model`` itself, or the model a :class:`ModelSnapshot` stands for (built on first use)."""
    return model.model() if isinstance(model, ModelSnapshot) else model


__all__ = ["ModelSnapshot", "SnapshotElement", "build_snapshot", "real_model", "snapshot_set"]
