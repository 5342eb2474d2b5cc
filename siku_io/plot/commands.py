"""``siku plot`` (maps and an animation from an output file or a gridded file), and the
pictures after ``siku run`` (``siku_draw``)."""
from __future__ import annotations

from siku_core import hookimpl


def _fsd_picture(args) -> list:
    """The floe size distribution (``siku fsd``) of an output file (``--fsd``) or of a
    distribution file ``siku fsd`` wrote, drawn into ``STEM_fsd.png``."""
    from pathlib import Path

    from siku_io.analysis.fsd_command import plot_fsd
    from siku_io.output.marks import netcdf_kind
    from siku_io.output.results import damaged
    from siku_io.plot.mapdeco import picture_targets

    path = Path(args.output)
    stem = path.name.removesuffix(".fsd.nc") if path.name.endswith(".fsd.nc") else path.stem
    (target,) = picture_targets(Path(args.out_dir) if args.out_dir else path.parent,
                                [f"{stem}_fsd.png"])
    if netcdf_kind(path) == "fsd":
        import xarray as xr

        with xr.open_dataset(path) as ds:
            plot_fsd(ds.load(), target)
    else:
        from siku_io.analysis.fsd import output_distribution

        with damaged(args.output):
            plot_fsd(output_distribution(path), target)
    return [target]


def _cmd_plot(args) -> int:
    from siku_io.output.marks import netcdf_kind
    from siku_io.plot.element_maps import plot_all
    from siku_io.plot.grid_maps import is_grid_file, plot_grid

    from siku_io.output.results import damaged

    if args.fsd or netcdf_kind(args.output) == "fsd":
        for f in _fsd_picture(args):
            print(f)
        return 0
    grid = is_grid_file(args.output)
    draw = plot_grid if grid else plot_all
    with damaged(args.output, "gridded file" if grid else "siku output file"):
        files = draw(args.output, args.out_dir, args.field, animation=not args.no_animation)
    for f in files:
        print(f)
    return 0


@hookimpl
def siku_draw(path, field):
    """The maps and animation of ``siku plot`` after a run that asks for them."""
    from siku_io.output.results import damaged
    from siku_io.plot.element_maps import plot_all

    with damaged(path):
        return plot_all(path, field=field)


@hookimpl
def siku_register_commands(subparsers):
    pl = subparsers.add_parser("plot", help="draw maps and an animation from an output file")
    pl.add_argument("output", help="HDF5 output file of a run, a gridded file of 'siku grid' "
                    "or a floe size distribution of 'siku fsd'")
    pl.add_argument("--field", help="per-element field to colour by (damage, speed, stress_ee "
                    "...), or for a gridded file the field to map (total_deformation, "
                    "concentration, stress_I ...)")
    pl.add_argument("--out-dir", help="directory for the pictures (default: beside the file)")
    pl.add_argument("--no-animation", action="store_true", help="maps only")
    pl.add_argument("--fsd", action="store_true", help="draw the floe size distribution of "
                    "the output file (as 'siku fsd --plot') instead of maps")
    pl.set_defaults(func=_cmd_plot)


