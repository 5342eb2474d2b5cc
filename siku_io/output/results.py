"""Reading siku's HDF5 output files: the complete snapshots only, and files a killed run left.

The number of complete snapshots is the length of ``/states/step`` (``siku_io.output.hdf5`` says how
the writer keeps it so); a killed writer leaves HDF5's "open for writing" mark, which
:func:`open_results` clears (as ``h5clear -s`` does) when no process holds the file.
"""
from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from siku_core import DataError
from siku_core.errors import SikuError
from siku_core.geometry.sphere import lonlat_to_xyz
from siku_core.run.outputs import in_use
from siku_core.run.restart import RAGGED_HISTORY

from .open_mark import MarkedReader, clear_open_mark  # noqa: F401 - re-exported, as before

#: the file layout this version writes and reads (``siku_io.output.hdf5``)
LAYOUT = 2


def open_results(path: str | Path):
    """Open a siku HDF5 output file for reading (an ``h5py.File``), or a Zarr output store
    (a :class:`~siku_io.output.zarr_read.ZarrFile`, read through the same interface).

    The file is first identified as siku's (``siku_io.output.marks``), reading only: any other
    file is refused untouched. A file a killed run left behind is opened after
    :func:`clear_open_mark` when no process holds it; a file a run is still writing is opened
    in SWMR read mode. Use :func:`n_snapshots` for the number of
    complete snapshots."""
    import h5py

    from .marks import is_hdf5_output, netcdf_kind

    path = Path(path)
    if path.is_dir():  # a store of the Zarr writer (siku_io.output.zarr_read)
        from .marks import is_zarr_output
        from .zarr_read import ZarrFile

        if not is_zarr_output(path):
            raise DataError(f"{path}: is a folder but not a siku Zarr output store (no siku "
                            "attributes in its zarr.json); give the output of a run")
        try:
            return ZarrFile(path)
        except Exception as exc:  # noqa: BLE001 - any error of the library on a damaged store
            raise DataError(f"{path}: not a readable Zarr store: {exc}") from None
    if not path.is_file():
        raise DataError(f"{path}: output file not found")
    if not is_hdf5_output(path):  # identified before anything else is done to it
        kind = netcdf_kind(path)
        raise DataError(f"{path}: " + (f"is a {kind} file of siku (NetCDF), not the HDF5 "
                                       "output of a run" if kind else
                                       "not a siku HDF5 output file (no siku attributes, or "
                                       "damaged); give the HDF5 output of a run"))
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        if "already open for write" not in str(exc):
            raise DataError(f"{path}: not a readable HDF5 file: {exc}") from None
    try:
        if in_use(path):
            return h5py.File(path, "r", swmr=True)
        clear_open_mark(path)
        return h5py.File(path, "r")
    except OSError as exc:
        raise DataError(f"{path}: not a readable HDF5 file: {exc}") from None


@contextlib.contextmanager
def damaged(path: str | Path, what: str = "siku output file"):
    """Reading ``path``: an error the reading code did not foresee (a damaged or cut file whose
    datasets, attributes or values are not what siku writes) becomes one :class:`DataError`
    naming the file, never a traceback."""
    try:
        yield
    except (SikuError, KeyboardInterrupt, MemoryError, SystemExit):
        raise
    except Exception as exc:  # noqa: BLE001 - any library's error on a damaged file
        text = " ".join(str(exc).split())[:200]
        raise DataError(f"{path}: damaged or incomplete {what}, it cannot be read "
                        f"({type(exc).__name__}: {text}); rerun the scene that wrote it"
                        ) from None


def n_snapshots(f) -> int:
    """Number of complete snapshots in an open output file: the length of ``/states/step``."""
    return int(f["states/step"].shape[0]) if "states" in f and "step" in f["states"] else 0


def require_snapshot(path: str | Path, doing: str) -> None:
    """Refuse, in one line, an output that holds no complete snapshot (a run killed before its
    first one) before ``doing`` ("export", "grid", ...) spends any work on it."""
    with open_results(path) as f:
        if n_snapshots(f) == 0:
            raise DataError(f"{path}: holds no complete snapshot yet, nothing to {doing} (a "
                            "run killed before its first snapshot; rerun the scene)")


def check_layout(f, path: Path) -> None:
    if "states" not in f or "step" not in f["states"]:
        raise DataError(f"{path}: no element states (is it a siku output file?)")
    if int(f.attrs.get("layout", 1)) != LAYOUT:
        raise DataError(f"{path}: written by an older siku (file layout "
                        f"{int(f.attrs.get('layout', 1))}, this version reads {LAYOUT}); rerun "
                        "the scene to restart from it")


def last_snapshot(path: str | Path) -> dict[str, Any]:
    """The last complete snapshot of an output file, what a restart reads: ``step``, ``time``
    [s], ``q``, ``V`` [m/s], ``w`` [rad/s], ``history`` (``{component: {name: array}}``), and
    the file's ``record`` (run record) and ``n_steps``."""
    path = Path(path)
    with open_results(path) as f:
        check_layout(f, path)
        n = n_snapshots(f)
        if n == 0:
            raise DataError(f"{path}: holds no complete snapshot to restart from")
        s = f["states"]
        out: dict[str, Any] = {k: s[k][n - 1] for k in ("q", "V", "w")}
        out["step"] = int(s["step"][n - 1])
        out["time"] = float(s["time"][n - 1])
        out["history"] = {key: {name: ds[n - 1] for name, ds in g.items()}
                          for key, g in s["history"].items()} if "history" in s else {}
        out["record"] = json.loads(f["run_record"][()])
        out["n_steps"] = int(f.attrs["n_steps"])
        out["extended_from"] = extended_from(f)
        return out


def extended_from(f) -> int | None:
    """The end (in steps) of the run before the last ``--extend`` of an open output file (the
    note an extended run adds to the scene it stores), ``None`` for a run never extended."""
    import re

    text = f["scene"][()] if "scene" in f else b""
    text = text.decode("utf-8", "replace") if isinstance(text, bytes) else str(text)
    found = re.findall(r"^# siku run --extend .*continued from step \d+ of (\d+) to step \d+",
                       text, flags=re.M)
    return int(found[-1]) if found else None


def run_progress(path: str | Path) -> dict[str, Any]:
    """How far the run in an output file got: ``step`` (of its last complete snapshot; -1 with
    none), ``n_steps`` (the steps its scene asks for), ``complete`` (``step == n_steps``) and
    ``scene_sha256`` (of the scene text the file records)."""
    path = Path(path)
    with open_results(path) as f:
        check_layout(f, path)
        n = n_snapshots(f)
        step = int(f["states/step"][n - 1]) if n else -1
        n_steps = int(f.attrs["n_steps"])
        return {"step": step, "n_steps": n_steps, "complete": step == n_steps,
                "scene_sha256": str(f.attrs.get("scene_sha256", ""))}


def read_diagnostics(path: str | Path) -> dict[str, tuple[np.ndarray, str]]:
    """The complete rows of every diagnostic series of an output file: name -> (values, unit)
    (``time`` [s] and ``step`` included)."""
    path = Path(path)
    with open_results(path) as f:
        check_layout(f, path)
        g = f["diagnostics"]
        n = int(g["step"].shape[0])
        return {k: (ds[:n], str(ds.attrs.get("units", "1" if k == "step" else
                                             "s" if k == "time" else "")))
                for k, ds in g.items()}


def snapshot_drift(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(time [s], mean drift [m])`` at every complete snapshot: the mean great-circle
    distance of the free elements from where they were at the file's first snapshot."""
    path = Path(path)
    with open_results(path) as f:
        check_layout(f, path)
        n = n_snapshots(f)
        s = f["states"]
        time = s["time"][:n]
        free = f["geometry/flags"][:] == 0
        radius = float(f.attrs["radius"])
        lat, lon = s["lat"][:n][:, free], s["lon"][:n][:, free]
    if n == 0 or not free.any():
        return time, np.zeros(n)
    p = lonlat_to_xyz(lon, lat)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    dot = x * x[0] + y * y[0] + z * z[0]
    cross = np.sqrt((y * z[0] - z * y[0]) ** 2 + (z * x[0] - x * z[0]) ** 2
                    + (x * y[0] - y * x[0]) ** 2)
    return time, radius * np.arctan2(cross, dot).mean(axis=1)


def restart_snapshot(path: Path, n: int, history: dict) -> dict[str, Any]:
    """What a restart reads from ``path`` (``HDF5Writer.read_restart``): its last complete
    snapshot, checked against the scene's ``n`` elements and ``history`` arrays (by shape)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: restart file not found")
    try:
        with damaged(path, "restart file"):
            last = last_snapshot(path)
    except OSError as exc:
        raise DataError(f"{path}: cannot read restart file: {exc}") from None
    N = last["q"].shape[0] if np.ndim(last["q"]) == 2 else -1
    if N != n:
        raise DataError(f"{path}: restart has {N} elements but the scene builds {n}")
    for key, arrays in history.items():
        for name, arr in arrays.items():
            got = np.shape(last["history"].get(key, {}).get(name))
            want = np.shape(arr)
            cut = 1 if name in RAGGED_HISTORY and len(got) == len(want) else 0  # padded
            if got[cut:] != want[cut:]:
                raise DataError(f"{path}: restart holds history {key}/{name} of shape "
                                f"{got}, the scene builds {np.shape(arr)}; restart with "
                                "the scene that wrote the file")
    return {k: last[k] for k in ("step", "time", "q", "V", "w", "history", "record",
                                 "n_steps", "extended_from")}
