"""Build, validate, run and save a scene from Python, without writing TOML.

A :class:`SceneBuilder` holds the same tables and keys as a scene file (``docs/reference/
scene.md``) and is checked by the same code: :meth:`~SceneBuilder.validate` writes the TOML and
validates it exactly as ``siku run`` validates a file, so a misspelt key, a wrong type or a value
out of range stops with the same one-line :class:`~siku_core.errors.SceneError` (naming the
scene's label, the table and the key), and a scene built here runs bit for bit as the same
scene read from a file::

    from siku_core.scene.scene_api import SceneBuilder

    s = SceneBuilder("one floe", duration="2d", dt="1min")
    s.polygon([[-150.17, 74.955], [-149.83, 74.955], [-149.83, 75.045], [-150.17, 75.045]],
              thickness=1.0)
    s.forcing("air_drag", field={"type": "uniform", "params": {"u": 10.0, "v": 0.0}})
    s.forcing("water_drag")
    s.output(file="one_floe.h5", every="1h")
    sim = s.run(out=False)          # a Simulation, run to the end
    s.save("one_floe.toml")         # the same scene as a file; SceneBuilder.load reads one back
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import SceneError

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    if not isinstance(k, str):
        raise SceneError(f"scene keys are text: {k!r} ({type(k).__name__}) cannot be a key; "
                         "give its name as a string")
    return k if _BARE.match(k) else json.dumps(k)


def _value(v: Any) -> str:
    """One value as inline TOML."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if hasattr(v, "dtype") and getattr(v, "ndim", 1) == 0:  # numpy scalars
        v = v.item()
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else
                                            "-inf" if v == -math.inf else repr(v))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (_dt.datetime, _dt.date)):
        return v.isoformat()
    if isinstance(v, Path):
        return json.dumps(str(v), ensure_ascii=False)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    if hasattr(v, "tolist"):
        v = v.tolist()
    if isinstance(v, Sequence):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise SceneError(f"a value of type {type(v).__name__} cannot be written in a scene file; "
                     "give a number, text, a date, a list or a table")


def _is_table(v: Any) -> bool:
    return isinstance(v, Mapping)


def _is_table_list(v: Any) -> bool:
    return isinstance(v, Sequence) and not isinstance(v, str) and len(v) > 0 and all(
        isinstance(x, Mapping) for x in v)


def to_toml(data: Mapping[str, Any]) -> str:
    """Scene data (nested dicts and lists, as ``tomllib`` reads them) as TOML text: plain keys
    first, then ``[tables]`` and ``[[arrays of tables]]``, nested in order."""
    out: list[str] = []

    def emit(prefix: str, table: Mapping[str, Any]) -> None:
        plain = [(k, v) for k, v in table.items() if v is not None and not _is_table(v)
                 and not _is_table_list(v)]
        for k, v in plain:
            try:
                out.append(f"{_key(k)} = {_value(v)}")
            except SceneError as exc:  # name the key the value was given for
                full = f"{prefix}.{k}" if prefix else str(k)
                raise SceneError(f"key '{full}': {exc}") from None
        for k, v in table.items():
            name = f"{prefix}.{_key(k)}" if prefix else _key(k)
            if _is_table(v):
                out.append(f"\n[{name}]")
                emit(name, v)
            elif _is_table_list(v):
                for item in v:
                    out.append(f"\n[[{name}]]")
                    emit(name, item)

    emit("", data)
    return "\n".join(out).lstrip("\n") + "\n"


def _when(v: Any) -> Any:
    """ISO date text as the datetime TOML would hold (other values as they are)."""
    if isinstance(v, str) and re.match(r"^\d{4}-\d\d-\d\d", v):
        try:
            return _dt.datetime.fromisoformat(v)
        except ValueError:
            return v
    return v


def _is_scene_file(path: Path) -> bool:
    """Is ``path`` a scene file (UTF-8 TOML text), one :meth:`SceneBuilder.save` may replace
    when told to?"""
    try:
        tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return True


class SceneBuilder:
    """A scene as Python data: ``data`` holds the tables of the TOML file (``{"time":
    {"duration": "2d"}, "forcing": [{"source": "air_drag"}], ...}``); the methods fill them.

    ``base_dir`` is the folder relative paths are read from (a scene file's own folder; default
    the working directory); ``name`` names the scene as a file would (its mesh cache, messages).
    """

    def __init__(self, title: str | None = None, *, duration: Any = None, dt: Any = None,
                 start: Any = None, end: Any = None, base_dir: str | Path | None = None,
                 name: str = "scene", label: str | None = None, **tables: Any) -> None:
        self.data: dict[str, Any] = {}
        if title is not None:
            self.data["title"] = title
        pairs = (("start", _when(start)), ("end", _when(end)), ("duration", duration), ("dt", dt))
        time = {k: v for k, v in pairs if v is not None}
        if time:
            self.data["time"] = time
        for k, v in tables.items():
            self.data[k] = v
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.name = name
        self.label = label

    # ------------------------------------------------------------------ reading and writing
    @classmethod
    def load(cls, source: str | Path) -> SceneBuilder:
        """A builder holding a scene file's tables (its folder is the ``base_dir``)."""
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise SceneError(f"{path}: scene file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
            raise SceneError(f"{path}: cannot read a scene file ({why}); give a TOML scene "
                             "file") from None
        b = cls.from_toml(text, base_dir=path.parent, name=path.stem, label=str(path))
        return b

    @classmethod
    def from_toml(cls, text: str, **kw: Any) -> SceneBuilder:
        """A builder holding the tables of scene TOML ``text``."""
        label = kw.get("label") or "<scene>"
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{label}: TOML syntax error: {exc}") from None
        b = cls(**kw)
        b.data = data
        return b

    def to_toml(self) -> str:
        return to_toml(self.data)

    def save(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write the scene as a TOML file (validated first: a file that would not run is not
        written), under the rule of every file siku writes
        (:func:`siku_core.run.outputs.check_target`): an existing ``path`` is refused unless
        ``overwrite=True`` and it is a scene file (TOML text); a symbolic link is never
        followed (``overwrite=True`` replaces the link, never its target); a FIFO, device or
        folder is refused without being opened. The file is written beside ``path`` and put in
        place in one rename. Refusals raise :class:`~siku_core.errors.DataError`."""
        from ..run.outputs import check_target, write_text_file

        self.validate()
        path = check_target(path, what="scene file", ours=_is_scene_file, overwrite=overwrite,
                            option="path", overwrite_option="overwrite=True",
                            follow_links=False)
        write_text_file(path, self.to_toml(), replace=overwrite)
        return path

    # ------------------------------------------------------------------ tables
    def set(self, key: str, value: Any) -> SceneBuilder:
        """Set a dotted key (``"time.duration"``, ``"forcing.0.params.C"``) as ``--set`` does;
        a key that names no place raises :class:`~siku_core.errors.SceneError` saying why."""
        if not isinstance(key, str) or not all(key.split(".")):
            raise SceneError(f"{self._label()}: cannot set {key!r}: give a dotted key such as "
                             "'time.duration' or 'forcing.0.params.C'")
        parts = key.split(".")
        cur: Any = self.data
        for part in parts[:-1]:
            if isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
                cur = cur[int(part)]
            elif isinstance(cur, dict):
                cur = cur.setdefault(part, {})
            else:
                raise SceneError(f"{self._label()}: cannot set '{key}': '{part}' is not a table")
        if isinstance(cur, list) and parts[-1].isdigit():
            if int(parts[-1]) >= len(cur):
                raise SceneError(f"{self._label()}: cannot set '{key}': the list holds "
                                 f"{len(cur)} tables (indices 0 to {len(cur) - 1}); add one "
                                 "with its method first")
            cur[int(parts[-1])] = value
        elif isinstance(cur, dict):
            cur[parts[-1]] = value
        else:
            raise SceneError(f"{self._label()}: cannot set '{key}': not a table key")
        return self

    def _table(self, name: str, kw: dict[str, Any]) -> SceneBuilder:
        self._part(self.data, name, dict).update({k: v for k, v in kw.items() if v is not None})
        return self

    def _part(self, parent: dict[str, Any], name: str, kind: type) -> Any:
        """``parent[name]``, made a ``kind`` (table or list of tables) when absent; another
        type there raises :class:`~siku_core.errors.SceneError` naming the key."""
        cur = parent.setdefault(name, kind())
        if not isinstance(cur, kind):
            want = "a table (dict)" if kind is dict else "a list of tables"
            raise SceneError(f"{self._label()}: '{name}' holds {type(cur).__name__} "
                             f"{cur!r:.40}, not {want}; set it to {want} or remove it")
        return cur

    def _append(self, table: str, name: str, entry: dict[str, Any]) -> SceneBuilder:
        """Append ``entry`` to the list of tables ``[[table.name]]`` (``name`` empty: the
        top-level ``[[table]]``)."""
        parent = self._part(self.data, table, dict) if name else self.data
        self._part(parent, name or table, list).append(entry)
        return self

    def time(self, **kw: Any) -> SceneBuilder:
        """``[time]``: ``start``, ``end`` (a datetime, or ISO text ``"2001-04-06T00:00:00Z"``),
        ``duration``, ``dt``."""
        return self._table("time", {k: _when(v) if k in ("start", "end") else v
                                    for k, v in kw.items()})

    def elements(self, **kw: Any) -> SceneBuilder:
        """``[elements]`` defaults: ``thickness``, ``material``."""
        return self._table("elements", kw)

    def polygon(self, vertices: Any, **kw: Any) -> SceneBuilder:
        """One ``[[elements.polygon]]``: ``vertices`` ``[[lon, lat], ...]`` in degrees."""
        return self._append("elements", "polygon", {"vertices": vertices, **kw})

    def pack(self, **kw: Any) -> SceneBuilder:
        """One ``[[elements.pack]]`` (``lon``, ``lat``, ``nx``, ``ny``, ...)."""
        return self._append("elements", "pack", dict(kw))

    def mesh(self, **kw: Any) -> SceneBuilder:
        """``[elements.mesh]``: Voronoi cells against a coastline (``lon``, ``lat``,
        ``spacing``, ...)."""
        self.data.setdefault("elements", {}).setdefault("mesh", {}).update(kw)
        return self

    def source(self, name: str, **kw: Any) -> SceneBuilder:
        """One ``[[elements.source]]`` (a registered element source, e.g. ``floe``)."""
        return self._append("elements", "source", {"name": name, **kw})

    def material(self, name: str, **kw: Any) -> SceneBuilder:
        """``[materials.NAME]``: ``density``, ``youngs_modulus``, ``poisson_ratio``."""
        self._part(self._part(self.data, "materials", dict), name, dict).update(kw)
        return self

    def forcing(self, source: str, *, field: Mapping[str, Any] | None = None,
                ramp: str | float | None = None, ramp_shape: str | None = None,
                **params: Any) -> SceneBuilder:
        """One ``[[forcing]]``: a registered forcing source, its ``params`` and ``field``, and
        its spin-up (``ramp``, ``ramp_shape``)."""
        table: dict[str, Any] = {"source": source}
        if params:
            table["params"] = params
        if field is not None:
            table["field"] = dict(field)
        if ramp is not None:
            table["ramp"] = ramp
        if ramp_shape is not None:
            table["ramp_shape"] = ramp_shape
        return self._append("forcing", "", table)

    def process(self, name: str, *, every: str | float | None = None,
                **params: Any) -> SceneBuilder:
        """One ``[[process]]``: a registered process, its ``params`` and interval ``every``."""
        table: dict[str, Any] = {"name": name}
        if params:
            table["params"] = params
        if every is not None:
            table["every"] = every
        return self._append("process", "", table)

    def contact(self, law: str, **kw: Any) -> SceneBuilder:
        """``[contact]``: ``law`` and its ``params``, ``joints``, ``broad_phase``, ..."""
        return self._table("contact", {"law": law, **kw})

    def integrator(self, name: str, **params: Any) -> SceneBuilder:
        self.data["integrator"] = {"name": name, **({"params": params} if params else {})}
        return self

    def output(self, **kw: Any) -> SceneBuilder:
        """``[output]``: ``file``, ``every``, ``plots``, ``grid``, ..."""
        return self._table("output", kw)

    def run_options(self, **kw: Any) -> SceneBuilder:
        """``[run]``: ``seed``, ``dt_safety``, ``max_speed``, ..."""
        return self._table("run", kw)

    # ------------------------------------------------------------------ checking and running
    def _label(self) -> str:
        return self.label or f"<scene {self.name!r} built in Python>"

    def _path(self) -> Path | None:
        return None if self.base_dir is None else self.base_dir / f"{self.name}.toml"

    def validate(self) -> Any:
        """The validated :class:`siku_core.scene.scene_file.Scene`, through the same code as a file
        (same
        checks, same one-line messages)."""
        from .scene_file import Scene, scene_from_text

        class _Labelled(Scene):  # later messages (plugins, data files) name the same label
            label = self._label()

        scene = scene_from_text(self.to_toml(), self._label(), self._path())
        scene.__class__ = _Labelled
        return scene

    def simulation(self, **kw: Any) -> Any:
        """A :class:`~siku_core.run.simulation.Simulation` of the scene (``out=False`` writes
        nothing; ``progress``, ``overwrite`` as for ``Simulation``)."""
        from ..run.simulation import Simulation

        return Simulation(self.validate(), **kw)

    def run(self, **kw: Any) -> Any:
        """Build the simulation and run it to the end; returns it."""
        return self.simulation(**kw).run()

    def __repr__(self) -> str:
        return f"SceneBuilder({self.name!r}, tables={sorted(self.data)})"
