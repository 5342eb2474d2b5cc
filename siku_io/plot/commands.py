"""``siku plot`` (maps and an animation from an output file or a gridded file), and the
pictures after ``siku run`` (``siku_draw``)."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_plot(args) -> int:
    from siku_io.plot.element_maps import plot_all
    from siku_io.plot.grid_maps import is_grid_file, plot_grid

    from siku_io.output.results import damaged

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
    pl.add_argument("output", help="HDF5 output file of a run, or a gridded file of 'siku grid'")
    pl.add_argument("--field", help="per-element field to colour by (damage, speed, stress_ee "
                    "...), or for a gridded file the field to map (total_deformation, "
                    "concentration, stress_I ...)")
    pl.add_argument("--out-dir", help="directory for the pictures (default: beside the file)")
    pl.add_argument("--no-animation", action="store_true", help="maps only")
    pl.set_defaults(func=_cmd_plot)


