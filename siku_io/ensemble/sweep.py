"""Sweep files: an ensemble of scenes as a base scene and its axes (``siku ensemble``).

A sweep file is TOML, strict like a scene file (an unknown key is an error naming it)::

    title = "Rheology comparison"
    scene = "rheology_comparison.toml"   # the base scene, relative to this file
    out_dir = "rheology"                 # member outputs and the summary (default: this
                                         # file's name without .toml), relative to this file

    [set]                                # every member, like siku run --set KEY=VALUE
    "time.duration" = "2h"

    [[axis]]                             # a dimension: one key and its values
    key = "contact.law"
    values = ["collision", "distributed_spring", "mohr_coulomb"]

    [[axis]]                             # zipped keys: one dimension, the lists move together
    name = "wind"
    zip = { "forcing.0.field.params.vmax" = [8.0, 11.0],
            "forcing.0.field.params.rmax" = [4e5, 5e5] }

    [[axis]]                             # random draws: n values per key, drawn together
    name = "sample"
    n = 8
    seed = 1
    draw = { "materials.ice.youngs_modulus" = { distribution = "loguniform",
                                                low = 5e8, high = 5e9 } }

    [replicates]                         # the whole product again, replicate r with seed + r
    n = 3
    key = "run.seed"

    [summary]                            # what the summary dataset holds
    final = ["joints_broken", "lead_fraction", "mean_drift"]   # default: every diagnostic
    series = ["lead_fraction"]           # time series (dimension time)
    file = "summary.nc"                  # in out_dir

    [cluster]
    scheduler = "tcp://10.0.0.1:8786"    # default: a local cluster
    workers = 2                          # local cluster: worker processes (default: cores)
    threads = 1                          # numba threads per member (default: cores / workers)
    timeout = 10                         # s to reach a scheduler

The members are the product of the axes (a zip or a draw axis is one dimension) times the
replicates. Keys are the keys of ``siku run --set`` (``forcing.0.field.params.vmax``: list items
by index); values are TOML values. Each member is the base scene with its keys set exactly as
``siku run BASE --set KEY=VALUE ... --out OUTPUT`` sets them (:meth:`Member.command`), so any
member reruns alone and gives the same file.

Draws (``distribution``): ``uniform`` (``low``, ``high``), ``loguniform`` (``low``, ``high``,
both > 0), ``normal`` (``mean``, ``std``), ``lognormal`` (``mean``, ``sigma`` of the natural
log), ``integers`` (``low`` to ``high`` inclusive), ``choice`` (``values``); numpy's default
generator seeded with the axis ``seed``, keys drawn in the order the file lists them.
"""
from __future__ import annotations

import copy
import datetime as _dt
import hashlib
import itertools
import json
import math
import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from pydantic import ValidationError

from siku_core.errors import SceneError
from siku_core.scene.scene_file import (
    Scene, SceneCfg, apply_overrides, override_value, read_input_text, scene_from_text,
)
from siku_core.scene.scene_messages import allowed_keys, explain_validation_error
from siku_io.ensemble.sweep_cfg import DERIVED, RESERVED, SweepCfg


# ---------------------------------------------------------------------------- values
#: most members one sweep may have (each is a run and a file)
MAX_MEMBERS = 100_000


def toml_value(v: Any) -> str:
    """``v`` as a TOML value, read back by ``--set`` to the same value (floats exactly)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        return ("nan" if x != x else "inf" if x > 0 else "-inf") if not math.isfinite(x) \
            else repr(x)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (_dt.datetime, _dt.date, _dt.time)):
        return v.isoformat()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(x)}"
                               for k, x in v.items()) + "}"
    raise TypeError(f"not a TOML value: {v!r}")


def _label(v: Any) -> str:
    """A value as part of a file name."""
    if isinstance(v, bool):
        s = "true" if v else "false"
    elif isinstance(v, (float, np.floating)):
        s = f"{float(v):g}"
    elif isinstance(v, (int, str, np.integer)):
        s = str(v)
    else:
        s = hashlib.sha256(toml_value(v).encode()).hexdigest()[:8]
    return re.sub(r"[^A-Za-z0-9.+=-]+", "_", s).strip("_.") or "_"


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, Mapping):
            out.update(_flatten(v, key))
        else:
            out[key] = v
    return out


# ---------------------------------------------------------------------------- the ensemble
@dataclass
class Axis:
    """One dimension: its name, the keys it sets and, per position, their values."""

    dim: str
    keys: list[str]
    rows: list[list[Any]]  # rows[i][k]: the value of keys[k] at position i
    labels: list[str]
    kind: str  # values, zip, draw, replicates

    def __len__(self) -> int:
        return len(self.rows)


@dataclass
class Member:
    """One scene of the ensemble."""

    index: tuple[int, ...]
    name: str
    overrides: dict[str, str]  # key -> TOML value, in the order siku run --set gets them
    output: Path
    scene_path: Path

    def scene(self, text: str) -> Scene:
        """The member's scene from the base scene's ``text`` (as ``load_scene`` makes it)."""
        return scene_from_text(text, str(self.scene_path), self.scene_path, self.overrides)

    def command(self) -> str:
        """The ``siku run`` command that runs this member alone (and writes the same file)."""
        sets = " ".join(f"--set {shlex.quote(f'{k}={v}')}" for k, v in self.overrides.items())
        return (f"siku run {shlex.quote(str(self.scene_path))} {sets} --out "
                f"{shlex.quote(str(self.output))}").replace("  ", " ")


@dataclass
class Sweep:
    """A validated sweep: its file, base scene, axes and members."""

    cfg: SweepCfg
    text: str
    label: str
    scene_path: Path
    scene_text: str
    out_dir: Path
    axes: list[Axis]
    members: list[Member] = field(default_factory=list)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)

    @property
    def summary_path(self) -> Path:
        return self.out_dir / self.cfg.summary.file

    @property
    def sha256(self) -> str:
        """What the members depend on: the sweep text and the base scene text."""
        return hashlib.sha256((self.text + "\0" + self.scene_text).encode()).hexdigest()


def _where(label: str, what: str) -> str:
    return f"{label} [{what}]"


def _default_dim(keys: list[str], taken: set[str]) -> str:
    """An axis's dimension name from its keys: the last part of the key (``contact.law`` ->
    ``law``), longer where that is taken (``run.max_speed`` -> ``run_max_speed``: the summary
    holds the diagnostic ``max_speed``)."""
    parts = [k.split(".") for k in keys]
    for n in range(1, max(len(p) for p in parts) + 1):
        name = "_".join("_".join(p[-n:]) for p in parts)
        name = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if name not in taken:
            return name
    return name


def _axes(cfg: SweepCfg, label: str) -> list[Axis]:
    from siku_core.diagnostics import catalogue

    axes: list[Axis] = []
    # names the summary's variables may take: its own, every diagnostic, the derived ones
    taken = set(RESERVED) | set(catalogue()) | set(DERIVED)
    for a_k, a in enumerate(cfg.axis):
        where = _where(label, f"axis[{a_k}]")
        if a.values is not None:
            keys, rows = [a.key], [[v] for v in a.values]
            labels, kind = [_label(v) for v in a.values], "values"
        elif a.zip is not None:
            keys = list(a.zip)
            rows = [list(r) for r in zip(*a.zip.values())]
            labels, kind = ["_".join(_label(v) for v in r) for r in rows], "zip"
        else:
            keys = list(a.draw)
            rng = np.random.default_rng(a.seed)
            cols = [a.draw[k].sample(rng, a.n) for k in keys]
            rows = [list(r) for r in zip(*cols)]
            labels, kind = [str(i) for i in range(a.n)], "draw"
        dim = a.name or _default_dim(keys, taken)
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", dim):
            raise SceneError(f"{where}: axis name '{dim}': use letters, digits and _ (it names "
                             "a dimension of the summary dataset); set name = \"...\"")
        if kind != "draw" and len({toml_value(r) for r in rows}) < len(rows):
            raise SceneError(f"{where}: '{', '.join(keys)}' repeats a value: each position of "
                             "an axis must differ (use [replicates] for repeats)")
        if len(set(labels)) < len(labels):
            w = len(str(len(labels) - 1))
            labels = [f"{i:0{w}d}-{s}" for i, s in enumerate(labels)]
        if kind == "draw":
            w = len(str(a.n - 1))
            labels = [f"{int(s):0{w}d}" for s in labels]
        axes.append(Axis(dim, keys, rows, labels, kind))
    if cfg.replicates is not None:
        r = cfg.replicates
        w = len(str(r.n - 1))
        axes.append(Axis("replicate", [r.key], [[r.seed + i] for i in range(r.n)],
                         [f"{i:0{w}d}" for i in range(r.n)], "replicates"))
    seen: dict[str, str] = {}
    for name in [a.dim for a in axes]:
        if name in taken or name in seen:
            raise SceneError(f"{label}: axis name '{name}' is "
                             + ("taken by a variable of the summary dataset" if name in taken
                                else "used twice") + "; give the axis another name = \"...\"")
        seen[name] = name
    keys_seen: dict[str, str] = {k: "set" for k in _flatten(cfg.set)}
    for a_k, a in enumerate(axes):
        for key in a.keys:
            if key in keys_seen:
                raise SceneError(f"{label}: key '{key}' is set by both {keys_seen[key]} and "
                                 f"axis '{a.dim}'")
            keys_seen[key] = f"axis '{a.dim}'"
    return axes


def _component_of(cfg: SceneCfg, prefix: str) -> tuple[str, str] | None:
    """The (kind, name) of the component whose ``params`` table is at ``prefix``."""
    parts = prefix.split(".")
    try:
        if prefix == "integrator":
            return "integrator", cfg.integrator.name
        if prefix == "contact" and cfg.contact is not None:
            return "contact_law", cfg.contact.law
        if prefix == "output":
            return "writer", cfg.output.writer
        if parts[0] == "forcing" and len(parts) == 2:
            return "forcing", cfg.forcing[int(parts[1])].source
        if parts[0] == "forcing" and len(parts) == 3 and parts[2] == "field":
            f = cfg.forcing[int(parts[1])].field
            return ("field", f.type) if f is not None else None
    except (ValueError, IndexError):
        return None
    return None


def _check_key(sweep_label: str, where: str, key: str, value: Any, base: dict, scene_label: str,
               cfgs: list[SceneCfg], registry) -> None:
    """Refuse a key the scene does not have (naming the sweep file and the key)."""
    data = copy.deepcopy(base)
    try:
        apply_overrides(data, {key: toml_value(value)}, scene_label)
    except SceneError as exc:
        raise SceneError(f"{where}: key '{key}': {str(exc).split(': ', 1)[-1]}") from None
    try:
        SceneCfg.model_validate(data)
    except ValidationError as err:
        for e in err.errors():
            loc = ".".join(str(p) for p in e["loc"])
            if e["type"] == "extra_forbidden" and (loc == key or key.startswith(loc + ".")):
                allowed = ", ".join(allowed_keys(SceneCfg, tuple(e["loc"]))) or "(none)"
                raise SceneError(f"{where}: key '{key}' is not a key of the scene ('{loc}' is "
                                 f"unknown; allowed keys there: {allowed})") from None
    m = re.fullmatch(r"(.+)\.params\.([^.]+)(\..+)?", key)
    if m is None or not cfgs:
        return
    known = []
    for cfg in cfgs:
        comp = _component_of(cfg, m.group(1))
        if comp is None:
            continue
        cls = registry.entry(*comp)
        if cls is None:
            continue
        if m.group(2) in cls.cls.params:
            return
        known.append((comp, sorted(cls.cls.params)))
    if known:
        (kind, name), names = known[0]
        raise SceneError(f"{where}: key '{key}': {kind.replace('_', ' ')} '{name}' has no "
                         f"parameter '{m.group(2)}'; its parameters: {', '.join(names) or '-'}")


def sweep_from_text(text: str, label: str = "<sweep>", base_dir: Path | None = None,
                    out_dir: str | Path | None = None, registry=None) -> Sweep:
    """Parse and validate sweep TOML ``text``; paths are relative to ``base_dir`` (default:
    the working directory); errors name ``label`` and the key. ``out_dir`` overrides the
    file's."""
    base_dir = Path(base_dir) if base_dir is not None else Path.cwd()
    from siku_core.scene.scene_file import parse_toml

    data = parse_toml(text, label)
    try:
        cfg = SweepCfg.model_validate(data)
    except ValidationError as err:
        raise SceneError(explain_validation_error(err, label, SweepCfg)) from None
    scene_path = (base_dir / cfg.scene).resolve()
    if not scene_path.is_file():
        raise SceneError(f"{label}: key 'scene': scene file {scene_path} not found")
    try:
        scene_text = scene_path.read_text(encoding="utf-8")
        base = parse_toml(scene_text, str(scene_path))
    except (OSError, UnicodeDecodeError, SceneError) as exc:
        raise SceneError(f"{label}: key 'scene': cannot read {scene_path}: {exc}") from None
    axes = _axes(cfg, label)
    count = math.prod(len(a) for a in axes)
    if count > MAX_MEMBERS:
        raise SceneError(f"{label}: the axes make {count:.3g} members ("
                         + " x ".join(f"{a.dim} {len(a)}" for a in axes)
                         + f"), above the limit of {MAX_MEMBERS:.0e}; shorten the axes or "
                         "split the sweep")
    fixed = {k: toml_value(v) for k, v in _flatten(cfg.set).items()}
    if out_dir is None:
        out_dir = cfg.out_dir if cfg.out_dir is not None else Path(label).stem or "ensemble"
    out = (base_dir / Path(out_dir)).resolve()
    # every key exists in the scene (checked with each axis's first value, the components
    # of every member: a parameter key must belong to the component some member uses)
    from siku_core.plugins import get_registry

    reg = registry or get_registry()
    members = _members(axes, fixed, out, scene_path)
    cfgs = []
    for m in members[:64]:
        try:
            cfgs.append(m.scene(scene_text).cfg)
        except SceneError:
            pass
    checks = [("set", k, override_value(v)) for k, v in fixed.items()]
    for a_k, a in enumerate(axes):
        what = "replicates" if a.kind == "replicates" else f"axis[{a_k}]"
        checks += [(what, k, a.rows[0][i]) for i, k in enumerate(a.keys)]
    for what, key, value in checks:
        _check_key(label, _where(label, what), key, value, base, str(scene_path), cfgs, reg)
    from siku_core.diagnostics import catalogue

    known = {**catalogue(reg), **DERIVED}
    known.pop("step"), known.pop("time")
    for what, names in (("final", cfg.summary.final or []), ("series", cfg.summary.series)):
        for name in names:
            if name not in known:
                raise SceneError(f"{_where(label, 'summary')} key '{what}': '{name}' is not a "
                                 f"diagnostic; known: {', '.join(sorted(known))}")
    return Sweep(cfg, text, label, scene_path, scene_text, out, axes, members)


def _members(axes: list[Axis], fixed: dict[str, str], out: Path, scene_path: Path
             ) -> list[Member]:
    members = []
    for index in itertools.product(*(range(len(a)) for a in axes)):
        overrides = dict(fixed)
        parts = []
        for a, i in zip(axes, index):
            for k, key in enumerate(a.keys):
                overrides[key] = toml_value(a.rows[i][k])
            parts.append(f"{a.dim}-{a.labels[i]}")
        name = "__".join(parts) or "member"
        if len(name) > 200:  # file names stop at 255 bytes
            name = "member-" + "-".join(str(i) for i in index)
        members.append(Member(tuple(index), name, overrides, out / f"{name}.h5", scene_path))
    return members


def load_sweep(path: str | Path, out_dir: str | Path | None = None, registry=None) -> Sweep:
    """Read and validate a sweep file (module docstring); ``out_dir`` overrides the file's."""
    p = Path(path)
    return sweep_from_text(read_input_text(p, "sweep file"), str(p), p.resolve().parent,
                           out_dir, registry)


__all__ = [
    "Axis",
    "Member",
    "Sweep",
    "SweepCfg",
    "load_sweep",
    "sweep_from_text",
    "toml_value",
]
