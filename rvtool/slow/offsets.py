"""Gap offsets written by the slow processes for the next contact evaluation.

A contact *selector* is either a full contact identity (``"pins/17"``) or a
contact-set name (``"pins"``), which selects every identity ``"pins/<k>"``.
Offsets are signed gap changes [m]: positive opens the gap (more clearance,
less interference), as wear and a hotter housing do; negative closes it.
Each channel (a thermal expansion map, the wear contribution) keeps its own
table, so a change of the next mechanical solution can be traced to the
channel that wrote it (Section "Slow feedback through shared mechanical
channels").
"""
import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from ..errors import RvtoolInputError


def selects(selector: str, contact_id: str) -> bool:
    """True where ``selector`` is ``contact_id`` itself or the name of its contact set."""
    return contact_id == selector or contact_id.startswith(selector + "/")


def match_selector(table, contact_id: str, name: str):
    """Value of ``table`` (selector -> value) for ``contact_id``: the full identity wins over its set name.

    Raises RvtoolInputError naming ``name`` when no selector matches.
    """
    if contact_id in table:
        return table[contact_id]
    for selector, value in table.items():
        if selects(selector, contact_id):
            return value
    raise RvtoolInputError(f"{name} has no entry for contact {contact_id!r}; valid keys: the contact id or its set "
                           f"name; given: {sorted(table)[:8]}")


@dataclass(frozen=True, kw_only=True, eq=False)
class GapOffsets:
    """Gap offsets [m] by channel: ``by_channel[channel][selector]`` (positive opens the gap).

    A selector of one channel may be a set name (a uniform thermal offset of
    all pins) or single identities (a wear increment per contact).
    """
    by_channel: dict

    def __post_init__(self):
        table = {}
        for channel, entries in dict(self.by_channel).items():
            if not isinstance(channel, str) or not channel:
                raise RvtoolInputError(f"GapOffsets channel names must be non-empty str; got {channel!r}")
            row = {}
            for selector, value in dict(entries).items():
                if not isinstance(selector, str) or not selector:
                    raise RvtoolInputError(f"by_channel[{channel!r}] keys must be contact selectors (str); "
                                           f"got {selector!r}")
                v = float(value)
                if not math.isfinite(v):
                    raise RvtoolInputError(f"by_channel[{channel!r}][{selector!r}] = {value!r} is outside the valid "
                                           "range: finite gap offsets [m]")
                row[selector] = v
            table[channel] = MappingProxyType(row)
        object.__setattr__(self, "by_channel", MappingProxyType(table))

    @classmethod
    def none(cls):
        """No offset in any channel."""
        return cls(by_channel={})

    def channel_offset(self, channel: str, contact_id: str) -> float:
        """Offset [m] of ``contact_id`` written by ``channel`` (0 where the channel does not select it)."""
        return sum(v for s, v in self.by_channel.get(channel, {}).items() if selects(s, contact_id))

    def offset(self, contact_id: str) -> float:
        """Total offset [m] of ``contact_id`` over all channels."""
        return sum(self.channel_offset(c, contact_id) for c in self.by_channel)

    def offsets(self, ids) -> np.ndarray:
        """Total offsets [m] of the identities ``ids``, shape (len(ids),)."""
        return np.array([self.offset(i) for i in ids], dtype=np.float64)

    def merged(self, other: "GapOffsets") -> "GapOffsets":
        """Channels of both; a channel present in both is refused (each channel has one writer)."""
        clash = set(self.by_channel) & set(other.by_channel)
        if clash:
            raise RvtoolInputError(f"channels {sorted(clash)} are written twice; valid: each channel from one process")
        return GapOffsets(by_channel={**self.by_channel, **other.by_channel})

    def to_dict(self) -> dict:
        return {c: dict(e) for c, e in self.by_channel.items()}
