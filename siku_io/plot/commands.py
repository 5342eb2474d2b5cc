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
    times = [t for spec in args.time for t in spec.split(",") if t.strip()] if args.time else None
    options = {"times": times, "fmt": args.format, "dpi": args.dpi, "vmin": args.vmin,
               "vmax": args.vmax, "extent": args.extent, "projection": args.projection,
               "land": {"auto": None, "on": True, "off": False}[args.coast]}
    with damaged(args.output, "gridded file" if grid else "siku output file"):
        files = draw(args.output, args.out_dir, args.field,
                     animation=not args.no_animation and times is None, **options)
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
    from siku_io.plot.mapdeco import DPI, FORMATS, PROJECTIONS

    pl = subparsers.add_parser("plot", help="draw maps and an animation from an output file")
    pl.add_argument("output", help="HDF5 output file of a run, a gridded file of 'siku grid' "
                    "or a floe size distribution of 'siku fsd'")
    pl.add_argument("--field", help="per-element field to colour by (damage, speed, stress_ee "
                    "...), or for a gridded file the field to map (total_deformation, "
                    "concentration, stress_I ...)")
    pl.add_argument("--out-dir", help="directory for the pictures (default: beside the file)")
    pl.add_argument("--no-animation", action="store_true", help="maps only")
    pl.add_argument("--time", action="append", metavar="WHEN",
                    help="the snapshot(s) to map instead of the first and last: an index (0, "
                    "-1) or a model time with its unit (6h, 90min); repeat or separate by "
                    "commas; files STEM_FIELD_NNN.FMT, NNN the snapshot's index (no animation)")
    pl.add_argument("--format", choices=FORMATS, default="png",
                    help="png (raster), pdf or svg (vector) maps; the animation stays a GIF")
    pl.add_argument("--dpi", type=float, default=DPI,
                    help="resolution of PNG maps (and of images inside PDF and SVG) "
                    f"[dots per inch], default {DPI}")
    pl.add_argument("--extent", type=float, nargs=4, metavar=("LON0", "LON1", "LAT0", "LAT1"),
                    help="frame the map on this lon/lat box [deg] (default: the ice)")
    pl.add_argument("--vmin", type=float, help="lower colour limit [the field's units]")
    pl.add_argument("--vmax", type=float, help="upper colour limit [the field's units]")
    pl.add_argument("--projection", choices=PROJECTIONS, default="auto",
                    help="map projection (auto: polar stereographic poleward of 45 degrees, "
                    "else plate carree)")
    pl.add_argument("--coast", choices=("auto", "on", "off"), default="auto",
                    help="draw the GSHHG land (auto: when the run's scene has a coast)")
    pl.add_argument("--fsd", action="store_true", help="draw the floe size distribution of "
                    "the output file (as 'siku fsd --plot') instead of maps")
    pl.set_defaults(func=_cmd_plot)


