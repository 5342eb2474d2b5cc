"""``siku grid`` (the gridded fields and leads of an output file), ``siku deformation`` (its
deformation statistics: siku_io.analysis.deformation_stats), the check of
``[output.grid]`` before a run and its gridded file after it."""
from __future__ import annotations

from siku_core import hookimpl


def _grid_cfg(args):
    """The grid of ``siku grid``: the command line's, else the output's ``[output.grid]``."""
    from siku_forcing.gridded.regular_grid import GridCfg, grid_error

    given = {k: getattr(args, k) for k in ("kind", "lon", "lat", "x", "y", "resolution",
                                           "every", "hemisphere", "central_longitude",
                                           "true_scale_latitude", "lead_threshold")
             if getattr(args, k, None) is not None}
    if args.fields:
        given["fields"] = args.fields.split(",")
    if args.no_leads:
        given["leads"] = False
    base = {}
    if not {"lon", "lat", "x", "y"} & set(given):
        from siku_io.analysis.gridded_fields import scene_grid

        from siku_io.output.results import damaged

        with damaged(args.output):
            base = scene_grid(args.output)
        if base is None:
            from siku_core import DataError

            raise DataError(f"{args.output}: its scene has no [output.grid]; give the grid "
                            "(--lon W E --lat S N --resolution DEG, or --kind "
                            "polar_stereographic --x X0 X1 --y Y0 Y1 --resolution M)")
    try:
        return GridCfg(**{**base, **given})
    except ValueError as exc:
        raise grid_error(exc, "siku grid") from None


def _cmd_grid(args) -> int:
    from pathlib import Path

    from siku_io.analysis.gridded_fields import grid_output
    from siku_io.output.netcdf import write_netcdf

    cfg = _grid_cfg(args)
    out = Path(args.out) if args.out else Path(args.output).with_suffix(".grid.nc")
    inputs = [("the gridded output file", Path(args.output))]
    from siku_forcing.gridded.regular_grid import Grid
    from siku_io.output.marks import writable
    from siku_io.output.results import damaged, require_snapshot

    Grid(cfg, 6_371_000.0)  # a grid that cannot be built says so first (any radius)
    writable(out, "grid", overwrite=args.overwrite, inputs=inputs)  # refused before the work
    with damaged(args.output):
        require_snapshot(args.output, "grid")
        ds = grid_output(args.output, cfg, progress=not args.no_progress)
    write_netcdf(ds, out, overwrite=args.overwrite, inputs=inputs)
    n = int(ds.sizes.get("lead", 0))
    ny, nx = (ds.sizes[d] for d in (("lat", "lon") if cfg.kind == "lonlat" else ("y", "x")))
    print(f"{out}: {ds.sizes['time']} times on a {cfg.kind} grid of {ny} x {nx} cells; {n} "
          "leads")
    return 0


def _cmd_deformation(args) -> int:
    from siku_io.analysis.deformation_stats import output_statistics

    if args.scales is None:
        args.scales = "10,20,40,80,160,320,640" if args.sirex else "10,20,40,80"
    try:
        scales = [float(v) * 1e3 for v in args.scales.split(",")]
        steps = [int(v) for v in args.steps.split(",")]
    except ValueError:
        from siku_core import DataError

        raise DataError(f"siku deformation: --scales {args.scales!r} / --steps {args.steps!r}: "
                        "give comma-separated numbers (km; whole snapshot intervals)") from None
    if args.sirex:
        from siku_io.analysis.sirex import output_sirex
        from siku_io.output.results import damaged

        window = None
        if args.window:
            from siku_core.scene.units import parse_duration

            parts = args.window.split(",")
            try:
                if len(parts) != 2:
                    raise ValueError(args.window)
                window = tuple(parse_duration(v.strip()) for v in parts)
            except ValueError:
                from siku_core import DataError

                raise DataError(f"siku deformation: --window {args.window!r}: give two "
                                "durations FROM,TO (e.g. 24h,48h)") from None
        with damaged(args.output):
            stats = output_sirex(args.output, scales, steps, args.min_cover, window)
        print(stats.table())
        if args.plot:
            from siku_io.analysis.sirex import plot_sirex

            plot_sirex(stats, args.plot)
            print(f"{args.plot}: beta(q) and the rate distribution")
        return 0
    print(output_statistics(args.output, scales, steps, args.min_cover).table())
    return 0


@hookimpl
def siku_register_commands(subparsers):
    g = subparsers.add_parser(
        "grid", help="concentration, thickness, velocity, strain rates, stress and leads of an "
        "output file on a regular grid (CF-NetCDF)")
    g.add_argument("output", help="HDF5 output file of a run")
    g.add_argument("--kind", choices=("lonlat", "polar_stereographic"))
    g.add_argument("--lon", nargs=2, type=float, metavar=("WEST", "EAST"), help="degrees")
    g.add_argument("--lat", nargs=2, type=float, metavar=("SOUTH", "NORTH"), help="degrees")
    g.add_argument("--x", nargs=2, type=float, metavar=("X0", "X1"),
                   help="projected m (write -2000000, not -2e6: argparse takes -2e6 for an "
                   "option)")
    g.add_argument("--y", nargs=2, type=float, metavar=("Y0", "Y1"), help="projected m")
    g.add_argument("--resolution", type=float, help="cell size: degrees (lonlat) or m")
    g.add_argument("--hemisphere", choices=("north", "south"))
    g.add_argument("--central-longitude", type=float, help="degrees (default -45)")
    g.add_argument("--true-scale-latitude", type=float, help="degrees (default 70)")
    g.add_argument("--every", help="interval between gridded times (default: every snapshot)")
    g.add_argument("--fields", help="comma-separated fields (default: all)")
    g.add_argument("--lead-threshold", type=float, help="total deformation of a lead [1/day]")
    g.add_argument("--no-leads", action="store_true", help="skip the lead detection")
    g.add_argument("--out", help="NetCDF file (default: OUTPUT.grid.nc beside the output)")
    g.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    g.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    g.set_defaults(func=_cmd_grid)
    d = subparsers.add_parser(
        "deformation", help="deformation statistics of an output file: total deformation rate "
        "coarse-grained over length and time scales, scaling exponents, rate distribution")
    d.add_argument("output", help="HDF5 output file of a run")
    d.add_argument("--scales", help="length scales [km], comma-separated (the spatial fit "
                   "range; default 10,20,40,80, with --sirex 10,20,...,640)")
    d.add_argument("--steps", default="1", help="time scales in snapshot intervals, "
                   "comma-separated (the temporal fit range)")
    d.add_argument("--min-cover", type=float, default=0.5,
                   help="least share of a box the hull of its elements (with --sirex: its "
                   "cells) must cover")
    d.add_argument("--sirex", action="store_true",
                   help="the RGPS method (Lagrangian cells of the element centres, "
                   "coarse-grained): moments q = 0.5-3 and beta(q), the rate distribution's "
                   "tail, linear kinematic features, beside the RGPS values")
    d.add_argument("--window", help="with --sirex: the snapshots from FROM to TO after the "
                   "first only, e.g. 24h,48h")
    d.add_argument("--plot", help="with --sirex: draw beta(q) and the rate distribution into "
                   "this image file (PNG)")
    d.set_defaults(func=_cmd_deformation)


@hookimpl
def siku_configured(scene):
    """Check ``[output.grid]`` before the run starts."""
    table = scene.cfg.output.grid
    if table is not None:
        from siku_core.errors import SceneError
        from siku_forcing.gridded.regular_grid import GridCfg, grid_error

        try:
            GridCfg(**table)
        except ValueError as exc:
            raise SceneError(str(grid_error(exc, f"{scene.label}: [output.grid]"))) from None


@hookimpl
def siku_postprocess(path, scene, overwrite):
    """The gridded fields of ``[output.grid]`` after a complete run (``siku grid``)."""
    table = scene.cfg.output.grid
    if table is None:
        return []
    from pathlib import Path

    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg
    from siku_io.output.netcdf import write_netcdf

    cfg = GridCfg(**table)
    path = Path(path)
    target = Path(cfg.file) if cfg.file else path.with_suffix(".grid.nc")
    if not target.is_absolute():
        target = path.parent / target
    from siku_core.run.outputs import input_paths
    from siku_io.output.marks import writable

    if target.exists() and not overwrite:
        from siku_core import DataError

        raise DataError(f"{target}: exists, so [output.grid] was not written (the run's output "
                        f"{path} is complete); run 'siku grid {path} --out FILE', or the run "
                        "with --overwrite")
    inputs = [(k, p) for k, p in input_paths(scene, [("the run's output file", path)])
              if not k.startswith("[output.grid.")]  # the gridded file of an earlier run
    writable(target, "grid", overwrite=overwrite, option="[output.grid] file", inputs=inputs)
    return [write_netcdf(grid_output(path, cfg), target, overwrite=overwrite, inputs=inputs)]
