"""``siku export``: an output file in another format (CF-NetCDF); ``siku info``: a run's
summary from its output file."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_export(args) -> int:
    from siku_io.output.netcdf import export

    print(export(args.output, args.out, overwrite=args.overwrite))
    return 0


@hookimpl
def siku_register_commands(subparsers):
    e = subparsers.add_parser("export", help="write an output file in another format "
                              "(CF-NetCDF)")
    e.add_argument("output", help="HDF5 output file of a run")
    e.add_argument("--to", choices=("netcdf",), default="netcdf", help="format (netcdf)")
    e.add_argument("--out", help="file to write (default: OUTPUT.nc beside the output)")
    e.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    e.set_defaults(func=_cmd_export)
    from siku_io.output.info import add_info_command

    add_info_command(subparsers)


