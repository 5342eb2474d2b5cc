"""Declared component parameters (with units and ranges) and their validation.

A component declares ``params = {"C": Param(0.0016, "1", "air drag coefficient", min=0)}``.
Scene values are validated with a pydantic model built from those declarations, and every
failure becomes a :class:`~siku_core.errors.SceneError` that names the file, the key and the
allowed values.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Mapping

from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model

from .errors import SceneError


@dataclass(frozen=True)
class Param:
    """One component parameter.

    Attributes
    ----------
    default : the value used when the scene does not set it (``None``: required).
    unit : SI unit as text (``"m/s"``, ``"Pa"``, ``"1"`` for dimensionless, ``"deg"``).
    doc : one line saying what it is.
    type : ``float``, ``int``, ``bool``, ``str``, ``list`` or ``dict``.
    min, max : inclusive bounds for numbers (``None``: unbounded).
    choices : allowed values for strings.
    """

    default: Any
    unit: str
    doc: str
    type: type = float
    min: float | None = None
    max: float | None = None
    choices: tuple | None = None

    def allowed(self) -> str:
        """Human-readable allowed values."""
        if self.choices:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        tname = self.type.__name__
        if self.min is not None and self.max is not None:
            return f"{tname} in [{self.min:g}, {self.max:g}] {self.unit}"
        if self.min is not None:
            return f"{tname} >= {self.min:g} {self.unit}"
        if self.max is not None:
            return f"{tname} <= {self.max:g} {self.unit}"
        return f"{tname} ({self.unit})" if self.unit else tname


_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


def _field(p: Param):
    ann: Any = p.type
    if p.choices:
        ann = Literal[p.choices]  # type: ignore[valid-type]
    kw: dict[str, Any] = {}
    if p.min is not None:
        kw["ge"] = p.min
    if p.max is not None:
        kw["le"] = p.max
    default = ... if p.default is None else p.default
    return (ann, Field(default, description=f"{p.doc} [{p.unit}]", **kw))


def params_model(name: str, spec: Mapping[str, Param]) -> type[BaseModel]:
    """A strict pydantic model for one component's parameters."""
    fields = {k: _field(p) for k, p in spec.items()}
    return create_model(f"{name}_params", __config__=_STRICT, **fields)


def format_validation_error(
    err: ValidationError, where: str, allowed: Mapping[str, str] | None = None
) -> str:
    """One line per problem: ``file: [section] key 'k': problem; allowed: ...``."""
    lines = []
    for e in err.errors():
        loc = ".".join(str(x) for x in e["loc"])
        kind = e["type"]
        if kind == "extra_forbidden":
            known = ", ".join(sorted(allowed)) if allowed else "(none)"
            lines.append(f"{where}: unknown key '{loc}'; allowed keys: {known}")
            continue
        got = e.get("input")
        hint = ""
        if allowed and loc.split(".")[0] in allowed:
            hint = f"; allowed: {allowed[loc.split('.')[0]]}"
        if kind == "missing":
            lines.append(f"{where}: missing required key '{loc}'{hint}")
        else:
            lines.append(f"{where}: key '{loc}' = {got!r}: {e['msg'].lower()}{hint}")
    return "\n".join(lines)


def validate_params(
    component: str, spec: Mapping[str, Param], given: Mapping[str, Any] | None, where: str
) -> dict[str, Any]:
    """Validate ``given`` against ``spec``; return the full parameter dict with defaults.

    ``where`` names the file and table, e.g. ``"scene.toml [forcing.1.params]"``.
    """
    model = params_model(component, spec)
    try:
        obj = model(**dict(given or {}))
    except ValidationError as err:
        allowed = {k: p.allowed() for k, p in spec.items()}
        raise SceneError(
            format_validation_error(err, f"{where} ({component})", allowed)
        ) from None
    return obj.model_dump()
