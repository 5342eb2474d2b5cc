"""Durations written with units in scene files ("6h", "30 min", "2d", 90)."""
from __future__ import annotations

import re

_UNITS = {
    "s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0,
    "min": 60.0, "minute": 60.0, "minutes": 60.0,
    "h": 3600.0, "hr": 3600.0, "hour": 3600.0, "hours": 3600.0,
    "d": 86400.0, "day": 86400.0, "days": 86400.0,
}
_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-zA-Z]*)\s*$")


def parse_duration(value: object) -> float:
    """Seconds from a number (already seconds) or a string with a unit: s, min, h, d."""
    if isinstance(value, bool):
        raise ValueError("a duration must be a number of seconds or a string like '6h'")
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        m = _RE.match(value)
        if m:
            unit = m.group(2)
            if not unit:  # text without a unit: 6 of what? (a number is seconds)
                raise ValueError(f"duration {value!r} has no unit; write {value.strip()}s, "
                                 f"{value.strip()}min, {value.strip()}h or {value.strip()}d "
                                 "(in a scene file a number is seconds)")
            if unit in _UNITS:
                return float(m.group(1)) * _UNITS[unit]
        raise ValueError(
            f"cannot read duration {value!r}; write seconds or a number with one of the units "
            "s, min, h, d (e.g. '6h')"
        )
    raise ValueError("a duration must be a number of seconds or a string like '6h'")
