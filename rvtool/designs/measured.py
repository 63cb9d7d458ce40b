"""Published measurements of a shipped design (``<design>_measured.toml``): figures measured on
prototypes in a cited paper, not catalogue figures (issue 30, Deliver 3: TE against a measurement).

Schema::

    format_version = 2
    design = "rv80e"
    tolerances_commit = "..."   (optional: the commit that fixed <design>_tolerances.toml before the comparison)
    [source]            title, authors, reference (journal, volume, year, article), read_through
                        (where it was read, when not from the printed page), status ("read" | "transcribed")
    [[transmission_error]]  specimen, low, high (the measured TE range over the output revolution),
                        unit (as printed), model_low, model_high (optional: the paper's own model), conditions

:func:`load_measured` returns a frozen :class:`Measured` in SI (rad); bad input raises
:class:`~rvtool.errors.RvtoolInputError` naming the key and its valid range.
"""
from dataclasses import dataclass

from ..errors import RvtoolInputError
from .catalogue import text_field

STATUSES = ("read", "transcribed")
"""How the figures were read: from the printed page, or through a cited transcription."""


@dataclass(frozen=True, kw_only=True)
class MeasuredSource:
    title: str
    authors: str
    reference: str
    status: str
    read_through: str | None = None

    def citation(self):
        s = f"{self.authors}, \"{self.title}\", {self.reference}"
        return s if self.read_through is None else f"{s} (read through {self.read_through})"


@dataclass(frozen=True, kw_only=True)
class MeasuredTE:
    """One specimen's measured TE range [low, high] [rad] (and as printed), the paper's own model range [rad] or
    None, the test conditions. ``peak_to_peak`` [rad] = high - low."""
    specimen: str
    low: float
    high: float
    unit: str
    low_printed: float
    high_printed: float
    conditions: str
    model_low: float | None = None
    model_high: float | None = None

    @property
    def peak_to_peak(self):
        return self.high - self.low


@dataclass(frozen=True, kw_only=True)
class Measured:
    design: str
    source: MeasuredSource
    transmission_error: tuple
    path: str
    tolerances_commit: str | None = None


def _number(table, key, where):
    v = table.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise RvtoolInputError(f"{where}.{key} = {v!r} is not valid (valid: a number)")
    return float(v)


def load_measured(path):
    """:class:`Measured` from a file path or a shipped name (``rv80e_measured``)."""
    from .catalogue import UNITS, read_data_file
    t, p = read_data_file(path, "measurement")
    design = text_field(t, "design", "file")
    tc = text_field(t, "tolerances_commit", "file", required=False)
    if tc is not None and not (len(tc) == 40 and all(c in "0123456789abcdef" for c in tc)):
        raise RvtoolInputError(f"tolerances_commit = {tc!r} is not valid (valid: a 40-digit lower-case hex git commit, "
                               "the commit that fixed the tolerance file before the comparison)")
    s = t.get("source")
    if not isinstance(s, dict):
        raise RvtoolInputError("section [source] is missing from the measurement file (title, authors, reference, "
                               "status)")
    status = text_field(s, "status", "source")
    if status not in STATUSES:
        raise RvtoolInputError(f"source.status = {status!r} is not valid (valid: {list(STATUSES)})")
    source = MeasuredSource(title=text_field(s, "title", "source"), authors=text_field(s, "authors", "source"),
                            reference=text_field(s, "reference", "source"), status=status,
                            read_through=text_field(s, "read_through", "source", required=False))
    if status == "transcribed" and source.read_through is None:
        raise RvtoolInputError("source.read_through is missing (valid: where the transcription was read, required "
                               "for status = 'transcribed')")
    raw = t.get("transmission_error", [])
    if not isinstance(raw, list):
        raise RvtoolInputError("transmission_error must be an array of tables ([[transmission_error]])")
    te = []
    for i, r in enumerate(raw):
        w = f"transmission_error[{i}]"
        unit = text_field(r, "unit", w)
        if unit not in ("arcsec", "arcmin", "rad", "deg"):
            raise RvtoolInputError(f"{w}.unit = {unit!r} is not valid (valid: ['arcsec', 'arcmin', 'rad', 'deg'])")
        f = UNITS[unit]
        lo, hi = _number(r, "low", w), _number(r, "high", w)
        if not lo < hi:
            raise RvtoolInputError(f"{w}.high = {hi!r} is outside the valid range ({lo!r}, inf) (above low)")
        ml = _number(r, "model_low", w) if "model_low" in r else None
        mh = _number(r, "model_high", w) if "model_high" in r else None
        if (ml is None) != (mh is None) or (ml is not None and not ml < mh):
            raise RvtoolInputError(f"{w}: model_low and model_high must both be given, model_low < model_high "
                                   f"(got {ml!r}, {mh!r})")
        te.append(MeasuredTE(specimen=text_field(r, "specimen", w), low=lo * f, high=hi * f, unit=unit, low_printed=lo,
                             high_printed=hi, conditions=text_field(r, "conditions", w),
                             model_low=None if ml is None else ml * f, model_high=None if mh is None else mh * f))
    return Measured(design=design, source=source, transmission_error=tuple(te), path=str(p), tolerances_commit=tc)
