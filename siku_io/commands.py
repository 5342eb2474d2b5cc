"""``siku plot`` (maps and an animation from an output file), ``siku ensemble`` (a sweep of
scenes on Dask) and ``siku bench`` (the benchmark runner of a source checkout), added through
``siku_register_commands``, and the pictures after ``siku run`` (``siku_draw``)."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_plot(args) -> int:
    from siku_io.plot import plot_all

    files = plot_all(args.output, args.out_dir, args.field, animation=not args.no_animation)
    for f in files:
        print(f)
    return 0


@hookimpl
def siku_draw(path, field):
    """The maps and animation of ``siku plot`` after a run that asks for them."""
    from siku_io.plot import plot_all

    return plot_all(path, field=field)


@hookimpl
def siku_register_commands(subparsers):
    pl = subparsers.add_parser("plot", help="draw maps and an animation from an output file")
    pl.add_argument("output", help="HDF5 output file of a run")
    pl.add_argument("--field", help="per-element field to colour by (damage, speed)")
    pl.add_argument("--out-dir", help="directory for the pictures (default: beside the file)")
    pl.add_argument("--no-animation", action="store_true", help="maps only")
    pl.set_defaults(func=_cmd_plot)


def _cmd_ensemble(args) -> int:
    from siku_io.ensemble import cmd_ensemble

    return cmd_ensemble(args)


@hookimpl(specname="siku_register_commands")
def register_ensemble(subparsers):
    en = subparsers.add_parser(
        "ensemble", help="run every member of a sweep file on a Dask cluster (a local one by "
        "default) and write a summary dataset")
    en.add_argument("sweep", help="sweep file (TOML): a base scene and its axes")
    en.add_argument("--scheduler", help="address of a running Dask scheduler (default: the "
                    "sweep's [cluster] scheduler, else a local cluster); 'serial' runs the "
                    "members one after another in this process")
    en.add_argument("--workers", type=int, help="local cluster: worker processes (default: "
                    "one per core)")
    en.add_argument("--threads", type=int, help="numba threads per member (default: cores / "
                    "workers)")
    en.add_argument("--out-dir", help="folder of the member outputs and the summary (default: "
                    "the sweep's out_dir)")
    en.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    en.set_defaults(func=_cmd_ensemble)


def _cmd_bench(argv: list[str]) -> int:
    """``siku bench ...``: ``python -m bench ...`` of the repository's ``bench/`` (benchmarks are
    not installed, so this needs a source checkout: an editable install), in its own process."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from siku_core.errors import SikuError

    root = Path(__file__).resolve().parents[1]
    if not (root / "bench" / "__main__.py").is_file():
        raise SikuError(f"siku bench needs a source checkout: {root / 'bench'} not found (siku "
                        "is not installed from a clone); clone the repository and run "
                        "'python -m bench' there")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH")) if p)
    return subprocess.call([sys.executable, "-m", "bench", *argv], env=env)


@hookimpl(specname="siku_register_commands")
def register_bench(subparsers):
    b = subparsers.add_parser("bench", help="benchmark tables (source checkout; 'siku bench "
                              "--help')", add_help=False)
    b.set_defaults(func=_cmd_bench, raw_args=True)
