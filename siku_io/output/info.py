"""``siku info FILE``: the summary ``siku run`` prints at its end, for any HDF5 output file or
Zarr output store (of a finished, running or interrupted run), read from the file alone."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from siku_core.errors import DataError
from siku_core.run.summary import RunSummary, format_summary


def summary_of_file(path: str | Path) -> RunSummary:
    """The run summary of an output file (finished, running or killed), read as every reader of
    outputs reads it (:func:`~siku_io.output.results.open_results`: identified in a child
    process with a time limit, a killed run's mark cleared, a running one read in SWMR mode),
    counting its complete snapshots only; :class:`~siku_core.errors.DataError` naming the file
    when it is not a siku output or is damaged."""
    from .results import damaged, n_snapshots, open_results

    path = Path(path)
    if path.is_dir():  # a Zarr store: open_results identifies it (siku_io.output.zarr_read)
        pass
    elif not path.is_file():
        raise DataError(f"{path}: no such file")
    else:
        with open(path, "rb") as fh:
            if fh.read(8) != b"\x89HDF\r\n\x1a\n":
                raise DataError(f"{path}: not an HDF5 file; give the HDF5 output of a run")
    with damaged(path), open_results(path) as f:
        if "geometry" not in f:
            raise DataError(f"{path}: not a siku output file (no /geometry)")
        a = f.attrs
        n = n_snapshots(f)  # rows past it belong to a commit a fault cut short
        steps = f["states/step"][:n]
        times = f["states/time"][:n] if "states/time" in f else np.zeros(0)
        diag: dict[str, float] = {}
        if "diagnostics" in f and "step" in f["diagnostics"] and len(f["diagnostics/step"]):
            g = f["diagnostics"]
            m = len(g["step"])
            diag = {k: float(g[k][m - 1]) for k in g if g[k].ndim == 1 and len(g[k]) >= m}
        wall = float(a["wall_time"]) if "wall_time" in a else None
        return RunSummary(
            title=str(a.get("title", "")), flags=f["geometry/flags"][:],
            steps=int(steps[-1]) if len(steps) else 0, n_steps=int(a.get("n_steps", 0)),
            dt=float(a.get("dt", float("nan"))),
            time=float(times[n - 1]) if n and len(times) >= n else 0.0, diagnostics=diag,
            wall=wall, output=str(path), start=str(a["start"]) if "start" in a else None,
            areas=f["geometry/area"][:] if "geometry/area" in f else None)


#: how long [s] reading one file's summary may take before the file is refused as damaged
#: (a summary reads a few small datasets: well under a second on any file siku wrote)
TIMEOUT = 60.0


def summary_text(path: str | Path, timeout: float | None = None) -> str:
    """The summary of an output file as text (:func:`summary_of_file`, formatted), read in a
    child process with a time limit (:func:`~siku_io.output.marks.in_child`), as every reader
    identifies a file: the HDF5 library can loop for ever or crash on data damaged inside a
    file whose marks read well; such a file is refused with one
    :class:`~siku_core.errors.DataError` naming it."""
    from siku_core.errors import SikuError

    from .marks import in_child

    def child() -> str:
        try:
            return "ok:" + format_summary(summary_of_file(path))
        except SikuError as exc:
            return "no:" + str(exc)

    answer = in_child(child, TIMEOUT if timeout is None else timeout)
    if answer is None:
        raise DataError(f"{path}: damaged siku output file: reading its summary did not end "
                        f"within {TIMEOUT if timeout is None else timeout:g} s (or the HDF5 "
                        "library failed on it); rerun the scene that wrote it")
    if answer.startswith("no:"):
        raise DataError(answer[3:])
    return answer[3:]


def _cmd_info(args) -> int:
    for i, p in enumerate(args.output):
        if i:
            print()
        print(summary_text(p))
    return 0


def add_info_command(subparsers) -> None:
    """Registered by ``siku_io.output.commands``."""
    p = subparsers.add_parser("info", help="summarise output files: elements, steps, joints "
                              "broken by mode, lead fraction, where they are")
    p.add_argument("output", nargs="+", help="output file(s) of siku run (HDF5 or Zarr)")
    p.set_defaults(func=_cmd_info)
