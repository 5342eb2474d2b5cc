"""The summary dataset of an ensemble (``siku_io.ensemble.runs``): one dimension per axis, the
diagnostics the sweep asks for (final values and time series, with units), each member's status,
message, output file and ``siku run`` command; written as NetCDF-4."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from siku_core import __version__
from siku_core.errors import SikuError
from siku_io.ensemble.sweep import DERIVED, Sweep

SUMMARY_KIND = "siku ensemble summary"


def _coord(values: list[Any]) -> np.ndarray:
    if all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.float64)
    if all(isinstance(v, str) for v in values):
        return np.array(values, dtype=object)
    from siku_io.ensemble.sweep import toml_value

    return np.array([toml_value(v) for v in values], dtype=object)


def summarize(sw: Sweep, results: Mapping[str, Mapping[str, Any]]):
    """The summary dataset of a sweep from its members' ``results`` and output files."""
    import xarray as xr

    dims = [a.dim for a in sw.axes]
    coords = _axis_coords(sw)
    cfg = sw.cfg.summary
    series = list(cfg.series)
    drift = cfg.final is None or "mean_drift" in cfg.final or "mean_drift" in series
    diag, results = _read_member_diagnostics(sw, results, drift)
    finals = _final_names(cfg.final, diag)
    times = sorted({float(t) for d in diag.values() for q in series if q in d
                    for t in _times_of(d, q)})
    data, units = _member_arrays(sw, results, diag, finals, series, times)
    variables = _summary_variables(dims, data, units, finals, series)
    if series:
        coords["time"] = ("time", np.array(times, dtype=np.float64),
                          {"units": "s", "long_name": "model time since the start of the run"})
    return xr.Dataset(variables, coords=coords, attrs=_summary_attrs(sw, results))


def _axis_coords(sw: Sweep) -> dict[str, Any]:
    """The coordinates of the sweep's axes: a ``values`` axis its values; any other axis an
    index along it, plus one coordinate per scene key it sets."""
    coords: dict[str, Any] = {}
    for a in sw.axes:
        if a.kind == "values":
            coords[a.dim] = (a.dim, _coord([r[0] for r in a.rows]),
                             {"scene_key": a.keys[0]})
        else:
            coords[a.dim] = (a.dim, np.arange(len(a)), {"long_name": f"{a.kind} index"})
            for k, key in enumerate(a.keys):
                coords[key] = (a.dim, _coord([r[k] for r in a.rows]), {"scene_key": key})
    return coords


def _read_member_diagnostics(sw: Sweep, results: Mapping[str, Mapping[str, Any]], drift: bool):
    """The diagnostics of every member that finished (``done`` or ``reused``), each output read
    once: ``{member: {quantity: (values, units)}}``, with ``mean_drift`` [m] and the snapshot
    times ``_snapshot_time`` [s] when ``drift``. A member whose output cannot be read is marked
    failed in the returned copy of ``results``."""
    from siku_io.output.results import read_diagnostics, snapshot_drift

    done = {m.name: m.output for m in sw.members
            if results.get(m.name, {}).get("status") in ("done", "reused")}
    diag: dict[str, dict[str, tuple[np.ndarray, str]]] = {}
    for name, path in done.items():
        try:
            d = read_diagnostics(path)
            if drift:
                t, v = snapshot_drift(path)
                d["mean_drift"] = (v, "m")
                d["_snapshot_time"] = (t, "s")
            diag[name] = d
        except (SikuError, OSError, KeyError) as exc:
            results = dict(results)
            results[name] = {**results[name], "status": "failed",
                             "message": f"{path}: cannot read its results: {exc}"}
    return diag, results


def _final_names(final: list[str] | None, diag: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """The quantities whose final values the summary holds: the ``[summary] final`` list, or
    without one every diagnostic some member reports, and the derived ones."""
    if final is not None:
        return list(final)
    return sorted(
        {k for d in diag.values() for k in d
         if k not in ("step", "time") and not k.startswith("_") and k not in DERIVED}
    ) + list(DERIVED)


def _times_of(d: Mapping[str, Any], q: str) -> np.ndarray:
    """The model times [s] of quantity ``q``'s records in one member's diagnostics ``d``."""
    return d["_snapshot_time"][0] if q in DERIVED else d["time"][0]


def _member_arrays(sw: Sweep, results, diag, finals: list[str], series: list[str],
                   times: list[float]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """One array per summary variable over the sweep's shape (the series with a trailing time
    dimension on ``times`` [s]), filled member by member, and the units of each quantity."""
    shape = sw.shape
    data: dict[str, Any] = {}
    for key, dtype in (("status", object), ("message", object), ("output", object),
                       ("command", object)):
        data[key] = np.empty(shape, dtype=dtype)
    data["wall_time"] = np.full(shape, np.nan)
    data["steps"] = np.zeros(shape, dtype=np.int64)
    for q in finals:
        data[q] = np.full(shape, np.nan)
    for q in series:
        data[f"{q}_series"] = np.full(shape + (len(times),), np.nan)
    tindex = {t: k for k, t in enumerate(times)}
    units: dict[str, str] = {}
    for m in sw.members:
        r = results.get(m.name, {"status": "failed", "message": "not run"})
        data["status"][m.index] = r["status"]
        data["message"][m.index] = r.get("message", "")
        data["output"][m.index] = str(m.output)
        data["command"][m.index] = m.command()
        data["wall_time"][m.index] = r.get("wall_time", math.nan)
        data["steps"][m.index] = r.get("steps", 0)
        d = diag.get(m.name)
        if d is None:
            continue
        for q in finals:
            if q in d and len(d[q][0]):
                data[q][m.index] = float(d[q][0][-1])
                units[q] = d[q][1]
        for q in series:
            if q in d:
                cols = [tindex[float(t)] for t in _times_of(d, q)]
                data[f"{q}_series"][m.index + (cols,)] = d[q][0]
                units[q] = d[q][1]
    return data, units


def _summary_variables(dims: list[str], data: Mapping[str, np.ndarray], units: Mapping[str, str],
                       finals: list[str], series: list[str]) -> dict[str, Any]:
    """The summary's data variables with their units and long names: the final values, the
    series, then each member's status, message, output, command, wall time [s] and steps."""
    from siku_core.diagnostics import catalogue

    known = catalogue()
    variables: dict[str, Any] = {}
    meaning = {**{k: v[1] for k, v in known.items()}, **{k: v[1] for k, v in DERIVED.items()}}
    for q in finals:
        variables[q] = (dims, data[q], {"units": units.get(q, known.get(q, ("",))[0]),
                                        "long_name": f"{meaning.get(q, q)} (at the end)"})
    for q in series:
        variables[f"{q}_series"] = (dims + ["time"], data[f"{q}_series"],
                                    {"units": units.get(q, known.get(q, ("",))[0]),
                                     "long_name": meaning.get(q, q)})
    variables["status"] = (dims, data["status"], {"long_name": "done, reused (complete output "
                                                  "of an earlier run) or failed"})
    variables["message"] = (dims, data["message"], {"long_name": "why a member failed"})
    variables["output"] = (dims, data["output"], {"long_name": "the member's output file"})
    variables["command"] = (dims, data["command"], {"long_name": "siku run command that runs "
                                                    "the member alone"})
    variables["wall_time"] = (dims, data["wall_time"], {"units": "s", "long_name": "wall-clock "
                                                        "time of the member's run"})
    variables["steps"] = (dims, data["steps"], {"long_name": "steps run by this sweep"})
    return variables


def _package_versions() -> dict[str, str]:
    """The versions of siku and of the installed packages a summary depends on."""
    import importlib.metadata as md

    versions = {"siku": __version__}
    for pkg in ("numpy", "numba", "dask", "distributed", "xarray", "h5py"):
        try:
            versions[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return versions


def _summary_attrs(sw: Sweep, results: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The summary's global attributes: the sweep and scene (files and text), the package
    versions, and the counts of members and of failed ones."""
    return {"kind": SUMMARY_KIND, "title": sw.cfg.title, "sweep": sw.text,
            "sweep_file": sw.label, "sweep_out_dir": str(sw.out_dir),
            "scene_file": str(sw.scene_path), "scene": sw.scene_text,
            "versions": json.dumps(_package_versions()), "n_members": len(sw.members),
            "n_failed": int(sum(1 for m in sw.members
                                if results.get(m.name, {}).get("status") == "failed"))}


def write_summary(ds, path: Path) -> Path:
    """Write the summary dataset as NetCDF-4, built beside ``path`` and renamed into place (a
    full disk leaves no partial file and an earlier summary whole)."""
    from siku_io.output.marks import write_whole

    enc = {k: {"dtype": str} for k, v in ds.variables.items() if v.dtype == object}
    return write_whole(Path(path), lambda part: ds.to_netcdf(part, engine="netcdf4",
                                                             encoding=enc), "summary")
