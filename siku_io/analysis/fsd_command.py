"""``siku fsd RUN.h5``: the floe size distribution of an output file (``siku_io.analysis.fsd``)
as a NetCDF dataset, a table on the terminal and, with ``--plot``, a picture."""
from __future__ import annotations

from siku_core import hookimpl


def plot_fsd(ds, target) -> None:
    """The density of floe areas at the first and last snapshots on log-log axes, with the
    fitted power law of the last one above its cut-off, saved to ``target``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(6, 4.5))
    x = ds["area_bin"].values
    for t in sorted({0, ds.sizes["time"] - 1}):
        p = ds["pdf"].values[t]
        ok = p > 0
        ax.loglog(x[ok], p[ok], "o-", label=f"t = {ds['time'].values[t]:g} s, "
                  f"{int(ds['n_floes'].values[t])} floes")
    t = ds.sizes["time"] - 1
    a, amin, se = (float(ds[k].values[t]) for k in ("alpha", "area_min", "alpha_se"))
    if np.isfinite(a):
        share = float(ds["n_tail"].values[t]) / float(ds["n_floes"].values[t])
        hi = x[ds["count"].values[t] > 0].max()
        xs = x[(x >= amin) & (x <= hi)]
        if len(xs):
            ax.loglog(xs, share * (a - 1) / amin * (xs / amin) ** (-a), "k--",
                      label=f"power law, alpha = {a:.2f} ± {se:.2f} above {amin:.3g} m²")
    ax.set_xlabel("floe area A [m²]")
    ax.set_ylabel("probability density p(A) [m⁻²]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    from siku_io.plot.mapdeco import save_png

    save_png(fig, target, dpi=120)  # siku's mark: drawn again by a later plot, never a user's
    plt.close(fig)


KIND = "siku floe size distribution"


def _ours(path) -> bool:
    """Whether ``path`` is a floe size distribution file ``siku fsd`` wrote."""
    try:
        import netCDF4

        with netCDF4.Dataset(path, "r") as nc:
            return "kind" in nc.ncattrs() and nc.getncattr("kind") == KIND
    except OSError:
        return False


def _write(ds, out, overwrite: bool, source) -> None:
    """Write ``ds`` to ``out`` atomically; an existing file only with ``overwrite`` and only
    when it is a file of this command; never the ``source`` output file."""
    from siku_core import DataError
    from siku_io.output.marks import write_whole

    if out.resolve() == source.resolve():
        raise DataError(f"{out}: --out names the output file itself; give another file")
    if out.exists() and not overwrite:
        raise DataError(f"{out}: exists; pass --overwrite to replace it")
    if out.exists() and not _ours(out):
        raise DataError(f"{out}: exists and is not a siku fsd file; not replaced")
    ds.attrs["kind"] = KIND
    write_whole(out, lambda part: ds.to_netcdf(part, format="NETCDF4", engine="netcdf4"),
                "fsd file", replace=True)


def _grid(args):
    """The grid of ``--grid``: the scene's ``[output.grid]``."""
    from siku_forcing.gridded.regular_grid import GridCfg, grid_error
    from siku_io.analysis.gridded_fields import scene_grid
    from siku_io.output.results import damaged

    with damaged(args.output):
        table = scene_grid(args.output)
    if table is None:
        from siku_core import DataError

        raise DataError(f"{args.output}: --grid needs the scene's [output.grid]; its scene "
                        "has none")
    try:
        return GridCfg(**table)
    except ValueError as exc:
        raise grid_error(exc, "siku fsd --grid") from None


def _cmd_fsd(args) -> int:
    from pathlib import Path

    import numpy as np

    from siku_io.analysis.fsd import output_distribution
    from siku_io.output.results import damaged

    cfg = _grid(args) if args.grid else None  # refused before the work
    with damaged(args.output):
        ds = output_distribution(args.output, per_decade=args.per_decade,
                                 min_tail=args.min_tail, free_only=not args.all_elements)
    out = Path(args.out) if args.out else Path(args.output).with_suffix(".fsd.nc")
    _write(ds, out, args.overwrite, Path(args.output))
    print(f"{'time [s]':>12} {'floes':>7} {'alpha':>7} {'se':>6} {'A_min [m2]':>11} "
          f"{'tail':>5}")
    for t in range(ds.sizes["time"]):
        v = {k: ds[k].values[t] for k in ("time", "n_floes", "alpha", "alpha_se", "area_min",
                                           "n_tail")}
        alpha = f"{v['alpha']:7.3f} {v['alpha_se']:6.3f}" if np.isfinite(v["alpha"]) else \
            f"{'-':>7} {'-':>6}"
        print(f"{v['time']:12g} {int(v['n_floes']):7d} {alpha} {v['area_min']:11.4g} "
              f"{int(v['n_tail']):5d}")
    if not np.all(np.isfinite(ds["alpha"].values)):
        from siku_io.analysis.fsd import MIN_BINS

        print(f"no power law ('-'): fewer than {args.min_tail} floes above a cut-off, or a "
              f"tail within fewer than {MIN_BINS} area bins")
    print(f"{out}: floe size distribution of {ds.sizes['time']} snapshots "
          f"({ds.attrs['floes']})")
    if args.plot:
        plot_fsd(ds, args.plot)
        print(f"{args.plot}: floe size distribution plot")
    if cfg is not None:
        from siku_io.analysis.gridded_fields import grid_distribution

        target = Path(args.grid)
        with damaged(args.output):
            g = grid_distribution(args.output, cfg)
        _write(g, target, args.overwrite, Path(args.output))
        print(f"{target}: floe sizes per cell of {g.sizes['time']} snapshots")
    return 0


@hookimpl
def siku_register_commands(subparsers):
    p = subparsers.add_parser(
        "fsd", help="floe size distribution of an output file: floes over intact joints, "
        "their areas and mean calipers, power-law exponent (NetCDF)")
    p.add_argument("output", help="HDF5 output file of a run")
    p.add_argument("--per-decade", type=int, default=5, help="area bins per decade")
    p.add_argument("--min-tail", type=int, default=10,
                   help="fewest floes above the power law's lower cut-off")
    p.add_argument("--all-elements", action="store_true",
                   help="count floes held by static or steady elements (coast cells) too; by "
                   "default only the free floes")
    p.add_argument("--out", help="NetCDF file (default: OUTPUT.fsd.nc beside the output)")
    p.add_argument("--plot", help="also draw the distribution into this image file (PNG)")
    p.add_argument("--grid", help="also write the floe sizes per cell of the scene's "
                   "[output.grid] into this NetCDF file")
    p.add_argument("--overwrite", action="store_true", help="replace existing files")
    p.set_defaults(func=_cmd_fsd)
