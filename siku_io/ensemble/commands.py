"""``siku ensemble``: a sweep of scenes on Dask."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_ensemble(args) -> int:
    from siku_io.ensemble.runs import cmd_ensemble

    return cmd_ensemble(args)


@hookimpl
def siku_register_commands(subparsers):
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


