"""Small scenes built from Python: square elements at given places, given forcing tables.

.. code-block:: python

    from siku_core.testing import make_scene

    scene = make_scene(
        elements=[(-150.0, 75.0), {"center": (180.0, 0.0), "velocity": (0.1, 0.0)}],
        forcing=[{"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}},
                 {"source": "coriolis"}],
        dt="1min", duration="1h",
    )

:func:`scene_text` returns the TOML text (what a user would write), :func:`make_scene` the
validated :class:`~siku_core.scene.scene_file.Scene`. Only the standard library, numpy and the scene
loader
are used: no plugin is imported.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..scene.scene_file import Scene, scene_from_text

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")

#: planet radius used for element geometry unless a scene says otherwise [m]
EARTH_RADIUS = 6_371_000.0


def toml_value(value: Any) -> str:
    """One value as inline TOML (strings, numbers, booleans, datetimes, lists, inline tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (_dt.datetime, _dt.date)):
        return value.isoformat()
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (Sequence, np.ndarray)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} {value!r} as TOML")


def toml_key(k: str) -> str:
    return k if _BARE_KEY.match(k) else json.dumps(k)


def _table(header: str, values: Mapping[str, Any]) -> str:
    lines = [header]
    lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in values.items() if v is not None]
    return "\n".join(lines)


def square(
    center: tuple[float, float], size: float = 10e3, radius: float = EARTH_RADIUS
) -> list[list[float]]:
    """``[lon, lat]`` vertices (degrees, counter-clockwise) of a square element.

    The square has side ``size`` [m] in the tangent plane at ``center = (lon, lat)`` [deg], sides
    along east and north (at a pole: along the directions east and north have at that longitude
    just off the pole), and its centroid at ``center``.
    """
    lon, lat = math.radians(center[0]), math.radians(center[1])
    c = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    east = np.array([-math.sin(lon), math.cos(lon), 0.0])
    north = np.cross(c, east)
    h = 0.5 * size / radius
    out = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        p = c + h * (sx * east + sy * north)
        p /= np.linalg.norm(p)
        out.append([math.degrees(math.atan2(p[1], p[0])),
                    math.degrees(math.atan2(p[2], math.hypot(p[0], p[1])))])
    return out


def _polygon_table(spec: Any, size: float, radius: float) -> dict[str, Any]:
    """An ``[[elements.polygon]]`` table from a centre, a vertex list or a dict."""
    if isinstance(spec, Mapping):
        d = dict(spec)
        if "vertices" not in d:
            d["vertices"] = square(tuple(d.pop("center")), float(d.pop("size", size)), radius)
        else:
            d.pop("size", None)
        return d
    arr = np.asarray(spec, dtype=float)
    if arr.shape == (2,):
        return {"vertices": square((float(arr[0]), float(arr[1])), size, radius)}
    return {"vertices": arr.tolist()}


def scene_text(
    elements: Sequence[Any] = ((-150.0, 75.0),),
    *,
    forcing: Sequence[Mapping[str, Any]] = (),
    integrator: str | Mapping[str, Any] = "siku2",
    dt: float | str = 60.0,
    duration: float | str = 600.0,
    start: _dt.datetime | None = None,
    size: float = 10e3,
    thickness: float | None = None,
    title: str = "siku test scene",
    planet: Mapping[str, Any] | None = None,
    materials: Mapping[str, Mapping[str, Any]] | None = None,
    packs: Sequence[Mapping[str, Any]] = (),
    output: Mapping[str, Any] | None = None,
    run: Mapping[str, Any] | None = None,
    extra: str = "",
) -> str:
    """Scene TOML for a few square elements and the given forcing tables.

    Parameters
    ----------
    elements : one entry per ``[[elements.polygon]]``: a centre ``(lon, lat)`` [deg] (a square of
        side ``size`` [m]), a list of ``[lon, lat]`` vertices, or a dict of polygon keys where
        ``center`` (and optionally ``size``) may replace ``vertices``, e.g.
        ``{"center": (0, 80), "velocity": (0.1, 0.0), "spin": 1e-5, "flag": "static"}``.
    forcing : ``[[forcing]]`` tables as dicts, e.g.
        ``{"source": "air_drag", "params": {"C": 0.002}, "field": {"type": "uniform"}}``.
    integrator : a name, or a dict ``{"name": ..., "params": {...}}``.
    dt, duration : seconds or strings with units (``"10min"``).
    start : optional start date (UTC).
    packs : ``[[elements.pack]]`` tables as dicts.
    planet, materials, output, run : the keys of those tables.
    extra : TOML text appended verbatim.
    """
    radius = float((planet or {}).get("radius", EARTH_RADIUS))
    parts = [f"title = {toml_value(title)}"]
    parts.append(_table("[time]", {"start": start, "duration": duration, "dt": dt}))
    if planet:
        parts.append(_table("[planet]", planet))
    for name, mat in (materials or {}).items():
        parts.append(_table(f"[materials.{toml_key(name)}]", mat))
    parts.append(_table("[elements]", {"thickness": thickness}))
    for spec in elements:
        parts.append(_table("[[elements.polygon]]", _polygon_table(spec, size, radius)))
    for pk in packs:
        parts.append(_table("[[elements.pack]]", pk))
    integ = {"name": integrator} if isinstance(integrator, str) else dict(integrator)
    parts.append(_table("[integrator]", integ))
    for f in forcing:
        parts.append(_table("[[forcing]]", f))
    if output:
        parts.append(_table("[output]", output))
    if run:
        parts.append(_table("[run]", run))
    if extra:
        parts.append(extra)
    return "\n\n".join(parts) + "\n"


def make_scene(*args: Any, label: str = "<test scene>", **kwargs: Any) -> Scene:
    """The validated :class:`~siku_core.scene.scene_file.Scene` of :func:`scene_text` (same
    arguments)."""
    return scene_from_text(scene_text(*args, **kwargs), label)


__all__ = ["EARTH_RADIUS", "make_scene", "scene_text", "square", "toml_value"]
