"""``siku info FILE``: the summary ``siku run`` prints at its end, for any HDF5 output file (of a
finished, running or interrupted run), read from the file alone."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from siku_core.errors import SceneError
from siku_core.summary import RunSummary, format_summary


def summary_of_file(path: str | Path) -> RunSummary:
    """The run summary of an output file; :class:`~siku_core.errors.SceneError` naming the file
    when it is not a siku output."""
    import h5py

    path = Path(path)
    if not path.is_file():
        raise SceneError(f"{path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise SceneError(f"{path}: not an HDF5 file ({exc})") from None
    with f:
        if "states" not in f or "geometry" not in f:
            raise SceneError(f"{path}: not a siku output file (no /states or /geometry)")
        a = f.attrs
        steps = f["states/step"][:] if "states/step" in f else np.zeros(0)
        times = f["states/time"][:] if "states/time" in f else np.zeros(0)
        diag: dict[str, float] = {}
        if "diagnostics" in f and "step" in f["diagnostics"] and len(f["diagnostics/step"]):
            g = f["diagnostics"]
            diag = {k: float(g[k][-1]) for k in g if g[k].ndim == 1 and len(g[k])}
        wall = float(a["wall_time"]) if "wall_time" in a else None
        return RunSummary(
            title=str(a.get("title", "")), flags=f["geometry/flags"][:],
            steps=int(steps[-1]) if len(steps) else 0, n_steps=int(a.get("n_steps", 0)),
            dt=float(a.get("dt", float("nan"))),
            time=float(times[-1]) if len(times) else 0.0, diagnostics=diag, wall=wall,
            output=str(path), start=str(a["start"]) if "start" in a else None,
            areas=f["geometry/area"][:] if "geometry/area" in f else None)


def _cmd_info(args) -> int:
    for i, p in enumerate(args.output):
        if i:
            print()
        print(format_summary(summary_of_file(p)))
    return 0


def add_info_command(subparsers) -> None:
    """Registered by ``siku_io.output.commands``."""
    p = subparsers.add_parser("info", help="summarise output files: elements, steps, joints "
                              "broken by mode, lead fraction, where they are")
    p.add_argument("output", nargs="+", help="HDF5 output file(s) of siku run")
    p.set_defaults(func=_cmd_info)
