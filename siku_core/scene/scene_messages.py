"""Messages for scene-like tables that fail validation: one line per problem, naming the file,
the key, the allowed keys or the allowed range (with its unit).

Shared by every strict table siku reads: the scene (:mod:`siku_core.scene.scene_file`) and the
tables of
the packages above the engine (sweeps, grids), so that their messages read alike.
"""
from __future__ import annotations

import re
import types
import typing
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ValidationError

from ..errors import SceneError
from .units import parse_duration


def _unwrap(ann: Any) -> Any:
    """Innermost pydantic model class of an annotation (list[X], X | None, dict[str, X])."""
    origin = typing.get_origin(ann)
    if origin is Annotated:
        return _unwrap(typing.get_args(ann)[0])
    if origin is None:
        return ann
    for a in typing.get_args(ann):
        inner = _unwrap(a)
        if isinstance(inner, type) and issubclass(inner, BaseModel):
            return inner
    return None


def allowed_keys(model: type[BaseModel], loc: tuple) -> list[str]:
    """The keys allowed in the table of ``model`` at a validation-error location."""
    cur: Any = model
    for part in loc[:-1]:
        if isinstance(part, str) and isinstance(cur, type) and issubclass(cur, BaseModel):
            f = cur.model_fields.get(part)
            if f is None:
                break
            cur = _unwrap(f.annotation)
    if isinstance(cur, type) and issubclass(cur, BaseModel):
        return sorted(cur.model_fields)
    return []


def _toml_path(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (("." if out else "") + str(part))
    return out


def _field_at(model: type[BaseModel], loc: tuple) -> Any:
    """The pydantic ``FieldInfo`` at a validation-error location, or ``None``."""
    cur: Any = model
    info = None
    dict_key = False
    for part in loc:
        if isinstance(part, int):
            continue
        if dict_key:  # a user-chosen key of a dict table, e.g. the NAME of [materials.NAME]
            dict_key = False
            continue
        if not (isinstance(cur, type) and issubclass(cur, BaseModel)):
            return None
        info = cur.model_fields.get(part)
        if info is None:
            return None
        args = (info.annotation, *typing.get_args(info.annotation))
        dict_key = any(typing.get_origin(a) is dict for a in args)
        cur = _unwrap(info.annotation)
    return info


def is_duration(model: type[BaseModel], loc: tuple) -> bool:
    """Whether the key at ``loc`` (``("time", "duration")``, list indices as ints) is a
    duration (a number of seconds or a string with a unit)."""
    info = _field_at(model, loc)
    if info is None:
        return False
    found: list[Any] = list(info.metadata)
    stack = [info.annotation]
    while stack:
        ann = stack.pop()
        if typing.get_origin(ann) is Annotated:
            found.extend(m for x in typing.get_args(ann)[1:] for m in getattr(x, "metadata", [x]))
            found.extend(typing.get_args(ann)[1:])
            stack.append(typing.get_args(ann)[0])
        elif typing.get_origin(ann) in (typing.Union, types.UnionType):
            stack.extend(typing.get_args(ann))
    return any(getattr(c, "func", None) is parse_duration for c in found)


def _allowed_range(model: type[BaseModel], loc: tuple) -> str:
    """``"0 <= key < 0.5 [1]"`` from a field's bounds and the unit in its description."""
    info = _field_at(model, loc)
    if info is None:
        return ""
    found: list[Any] = list(info.metadata)

    def walk(ann: Any) -> None:
        if typing.get_origin(ann) is Annotated:
            for m in typing.get_args(ann)[1:]:
                found.extend(getattr(m, "metadata", [m]))
            walk(typing.get_args(ann)[0])
        else:
            for a in typing.get_args(ann):
                walk(a)

    walk(info.annotation)
    lo = hi = ""
    for c in found:
        for attr, side, op in (("gt", "lo", "<"), ("ge", "lo", "<="), ("lt", "hi", "<"),
                               ("le", "hi", "<=")):
            v = getattr(c, attr, None)
            if v is not None and type(c).__name__.lower() == attr:
                if side == "lo":
                    lo = f"{v:g} {op} "
                else:
                    hi = f" {op} {v:g}"
    if not (lo or hi):
        return ""
    m = re.search(r"\[([^\]]+)\]\s*$", info.description or "")
    unit = m.group(1) if m else ""
    if any(getattr(c, "func", None) is parse_duration for c in found):
        unit = "s"
    return f"; allowed range: {lo}{loc[-1]}{hi}" + (f" [{unit}]" if unit else "")


def explain_validation_error(err: ValidationError, where: str, model: type[BaseModel]) -> str:
    """One line per problem of ``err`` (a validation of the pydantic ``model``: the scene's
    :class:`~siku_core.scene.scene_file.SceneCfg`, a sweep's, a grid's), each starting with
    ``where`` and
    naming the key, the allowed keys or the allowed range."""
    lines = []
    for e in err.errors():
        loc = tuple(e["loc"])
        path = _toml_path(loc)
        if e["type"] == "extra_forbidden":
            keys = ", ".join(allowed_keys(model, loc)) or "(none)"
            lines.append(f"{where}: unknown key '{path}'; allowed keys here: {keys}")
        elif e["type"] == "missing":
            lines.append(f"{where}: missing required key '{path}'")
        elif e["type"] == "value_error" and not path:
            lines.append(f"{where}: {e['msg'].removeprefix('Value error, ')}")
        else:
            msg = e["msg"].removeprefix("Value error, ")
            if "input" in e and e["type"] != "value_error":
                hint = ""
                if e["type"] in ("greater_than", "greater_than_equal", "less_than",
                                 "less_than_equal"):
                    hint = _allowed_range(model, loc)
                lines.append(
                    f"{where}: key '{path}' = {e['input']!r}: {msg[0].lower() + msg[1:]}{hint}"
                )
            else:
                lines.append(f"{where}: [{path}] {msg}")
    return "\n".join(lines)


#: the first bytes of the data files a scene is not: HDF5 and NetCDF (classic or 64-bit)
DATA_MAGIC = ((b"\x89HDF\r\n\x1a\n", "an HDF5 file"), (b"CDF\x01", "a NetCDF file"),
              (b"CDF\x02", "a NetCDF file"), (b"PK\x03\x04", "a zip archive"))


def data_file_kind(path: Path) -> str:
    """What data file ``path`` is by its first bytes (``""``: none of :data:`DATA_MAGIC`)."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except OSError:
        return ""
    return next((kind for magic, kind in DATA_MAGIC if head.startswith(magic)), "")


def read_input_text(path: str | Path, what: str = "scene file") -> str:
    """The UTF-8 text of an input file; a missing or unreadable one is a :class:`SceneError`
    naming it (``what``: how messages call it)."""
    from ..errors import shown

    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{shown(p)}: {what} not found")
    kind = data_file_kind(p)
    if kind:
        raise SceneError(f"{shown(p)}: is {kind} (a siku output?), not a {what}: read it with "
                         f"`siku info {shown(p)}`, or continue its run with `siku run SCENE "
                         f"--restart {shown(p)}`")
    try:
        return p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{p}: cannot read {what}: {exc}") from None
