"""Typed results of ``rvtool analyze``: a figure with its unit and error statement, a
protocol's result, the whole analysis. Plain frozen dataclasses; ``to_dict`` gives the
``results.json`` form. A non-finite figure value never reaches a result: it becomes None
with a warning naming the figure (a NaN in results.json would read as a number)."""
import math
from dataclasses import dataclass, field

import numpy as np

STATUSES = ("ok", "failed", "skipped")
"""ok: ran and produced its figures; failed: raised (the error is the reason, other protocols
still run); skipped: not applicable to this design or topology (the reason says why)."""


def finite_or_none(value):
    """(value with non-finite floats replaced by None, True when something was replaced)."""
    if isinstance(value, dict):
        out, bad = {}, False
        for k, v in value.items():
            out[k], b = finite_or_none(v)
            bad |= b
        return out, bad
    if isinstance(value, (list, tuple, np.ndarray)):
        items = [finite_or_none(v) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
        return [v for v, _ in items], any(b for _, b in items)
    if isinstance(value, (float, np.floating)):
        return (float(value), False) if math.isfinite(value) else (None, True)
    if isinstance(value, np.integer):
        return int(value), False
    if isinstance(value, np.bool_):
        return bool(value), False
    return value, False


@dataclass(frozen=True)
class Figure:
    """One reported figure: ``value`` in ``unit``; ``error`` (same unit, or relative where
    ``error_unit`` says so) against the reference named by ``error_statement``."""
    name: str
    value: object
    unit: str
    description: str
    error: float | None = None
    error_unit: str = ""
    error_statement: str = ""

    def to_dict(self):
        return {"value": self.value, "unit": self.unit, "description": self.description, "error": self.error,
                "error_unit": self.error_unit or self.unit, "error_statement": self.error_statement}


@dataclass(frozen=True)
class ProtocolResult:
    """Result of one protocol: status (:data:`STATUSES`), reason (failed/skipped), figures,
    the protocol's full data (arrays, per-branch tables), its settings, warnings, plot files
    (names in the output folder) and wall time [s]."""
    name: str
    status: str
    summary: str
    figures: tuple = ()
    data: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    warnings: tuple = ()
    plots: tuple = ()
    wall_s: float = 0.0
    reason: str = ""

    def figure(self, name):
        """The :class:`Figure` called ``name``."""
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(f"{self.name} has no figure {name!r}; figures: {[f.name for f in self.figures]}")

    def to_dict(self):
        return {"status": self.status, "summary": self.summary, "reason": self.reason,
                "figures": {f.name: f.to_dict() for f in self.figures}, "data": self.data,
                "settings": self.settings, "warnings": list(self.warnings), "plots": list(self.plots),
                "wall_s": self.wall_s}


@dataclass(frozen=True)
class AnalysisResult:
    """All protocols of one analysis, in the order run, with the design they ran on."""
    design_name: str
    topology: str
    source: str
    quick: bool
    device: str
    results: tuple
    out_dir: str | None = None
    wall_s: float = 0.0
    backend: str = "auto"
    bearing_model: str | None = None    # --bearing-model; None: the builders' default (lumped)

    @property
    def backends(self):
        """Per protocol that ran, the backend record {"requested", "ran", "not_taken": {name: reason}}."""
        return {r.name: r.settings["backend"] for r in self.results
                if r.status == "ok" and isinstance(r.settings, dict) and "backend" in r.settings}

    def __getitem__(self, name):
        for r in self.results:
            if r.name == name:
                return r
        raise KeyError(f"no protocol {name!r} in this analysis; protocols: {[r.name for r in self.results]}")

    @property
    def protocols(self):
        """Names of the protocols that ran (status ok or failed)."""
        return [r.name for r in self.results if r.status != "skipped"]

    @property
    def skipped(self):
        return {r.name: r.reason for r in self.results if r.status == "skipped"}

    @property
    def warnings(self):
        """Every protocol's warnings, prefixed with the protocol's name (failures included)."""
        out = []
        for r in self.results:
            if r.status == "failed":
                out.append(f"{r.name}: FAILED: {r.reason}")
            out += [f"{r.name}: {w}" for w in r.warnings]
        return out

    @property
    def ok(self):
        return all(r.status != "failed" for r in self.results)

    def to_dict(self):
        """The results.json keys (provenance is added by the writer)."""
        d = {"design": self.design_name, "topology": self.topology, "design_source": self.source,
             "quick": self.quick, "protocols": self.protocols, "skipped": self.skipped, "warnings": self.warnings,
             "backend_requested": self.backend, "backends": self.backends}
        for r in self.results:
            d[r.name] = r.to_dict()
        return d
