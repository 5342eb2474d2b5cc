"""``siku export``: an output file in another format (CF-NetCDF, or the same trajectory layout
as a Zarr store); ``siku info``: a run's summary from its output file."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_export(args) -> int:
    if args.to == "zarr":
        from siku_io.output.zarr_store import export_zarr

        print(export_zarr(args.output, args.out, overwrite=args.overwrite))
        return 0
    from siku_io.output.netcdf import export

    print(export(args.output, args.out, overwrite=args.overwrite))
    return 0


@hookimpl
def siku_register_commands(subparsers):
    e = subparsers.add_parser("export", help="write an output file in another format "
                              "(CF-NetCDF, Zarr)")
    e.add_argument("output", help="output of a run (HDF5 file or Zarr store)")
    e.add_argument("--to", choices=("netcdf", "zarr"), default="netcdf",
                   help="format: netcdf (a CF trajectory file) or zarr (the same layout as a "
                   "Zarr store)")
    e.add_argument("--out", help="file to write (default: OUTPUT.nc or OUTPUT.zarr beside the "
                   "output)")
    e.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    e.set_defaults(func=_cmd_export)
    from siku_io.output.info import add_info_command

    add_info_command(subparsers)
