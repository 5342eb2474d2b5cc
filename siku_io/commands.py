"""``siku plot`` (maps and an animation from an output file), ``siku ensemble`` (a sweep of
scenes on Dask) and ``siku bench`` (the benchmark runner of a source checkout), added through
``siku_register_commands``, and the pictures after ``siku run`` (``siku_draw``)."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_plot(args) -> int:
    from siku_io.plot import plot_all
    from siku_io.plot_grid import is_grid_file, plot_grid

    draw = plot_grid if is_grid_file(args.output) else plot_all
    files = draw(args.output, args.out_dir, args.field, animation=not args.no_animation)
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
    pl.add_argument("output", help="HDF5 output file of a run, or a gridded file of 'siku grid'")
    pl.add_argument("--field", help="per-element field to colour by (damage, speed, stress_ee "
                    "...), or for a gridded file the field to map (total_deformation, "
                    "concentration, stress_I ...)")
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


def _grid_cfg(args):
    """The grid of ``siku grid``: the command line's, else the output's ``[output.grid]``."""
    from siku_io.grid import GridCfg, grid_error

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
        from siku_io.grid import scene_grid

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

    from siku_io.gridding import grid_output, write_netcdf

    cfg = _grid_cfg(args)
    ds = grid_output(args.output, cfg, progress=not args.no_progress)
    out = Path(args.out) if args.out else Path(args.output).with_suffix(".grid.nc")
    write_netcdf(ds, out, overwrite=args.overwrite)
    n = int(ds.sizes.get("lead", 0))
    ny, nx = (ds.sizes[d] for d in (("lat", "lon") if cfg.kind == "lonlat" else ("y", "x")))
    print(f"{out}: {ds.sizes['time']} times on a {cfg.kind} grid of {ny} x {nx} cells; {n} "
          "leads")
    return 0


def _cmd_export(args) -> int:
    from siku_io.netcdf import export

    print(export(args.output, args.out, overwrite=args.overwrite))
    return 0


@hookimpl(specname="siku_register_commands")
def register_grid(subparsers):
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
    e = subparsers.add_parser("export", help="write an output file in another format "
                              "(CF-NetCDF)")
    e.add_argument("output", help="HDF5 output file of a run")
    e.add_argument("--to", choices=("netcdf",), default="netcdf", help="format (netcdf)")
    e.add_argument("--out", help="file to write (default: OUTPUT.nc beside the output)")
    e.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    e.set_defaults(func=_cmd_export)


@hookimpl
def siku_configured(scene):
    """Check ``[output.grid]`` and ``[coupling]`` before the run starts."""
    from siku_io.coupling import check_coupling

    check_coupling(scene)
    table = scene.cfg.output.grid
    if table is not None:
        from siku_core.errors import SceneError
        from siku_io.grid import GridCfg, grid_error

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

    from siku_io.grid import GridCfg
    from siku_io.gridding import grid_output, write_netcdf

    cfg = GridCfg(**table)
    path = Path(path)
    target = Path(cfg.file) if cfg.file else path.with_suffix(".grid.nc")
    if not target.is_absolute():
        target = path.parent / target
    if target.exists() and not overwrite:
        from siku_core import DataError

        raise DataError(f"{target}: exists, so [output.grid] was not written (the run's output "
                        f"{path} is complete); run 'siku grid {path} --out FILE', or the run "
                        "with --overwrite")
    return [write_netcdf(grid_output(path, cfg), target, overwrite=overwrite)]
