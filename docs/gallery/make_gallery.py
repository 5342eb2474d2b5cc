"""Draw every picture of the gallery (docs/gallery/*.png) with the current code, in one command:

    python docs/gallery/make_gallery.py [--only NAME ...] [--out DIR] [--hours H]

NAME: ``default`` (the default scene: damage at 0 h and 24 h, and broken joints with leads on a
polar stereographic grid), ``case`` (the 2001-04-06 case study on stand-in winds), ``waves``
(fragment length against wave amplitude), ``two_way`` (the coupled wave flume), ``ice_life``
(the cold snap and thaw of ``examples/ice_life``: thickness change and volume budget) and
``ice_edge`` (the ice edge experiment of ``examples/miz``: wave height and floe size over time,
attenuation and floe size distribution; about ten minutes). Runs take
place in a temporary folder (a copy of ``examples/`` where a picture needs it); only the
pictures are written, into ``--out`` (default: this folder). The default scene and the case run
24 h each (about six and four minutes on two cores); ``--hours`` shortens them (tests).
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
NAMES = ("default", "case", "waves", "two_way", "ice_life", "ice_edge")


def _run(cmd: list[str], cwd: Path) -> None:
    print("$", " ".join(cmd), flush=True)
    subprocess.run(cmd, cwd=cwd, check=True)


def default(work: Path, out: Path, hours: float) -> list[Path]:
    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg
    from siku_io.output.netcdf import write_netcdf
    from siku_io.plot.element_maps import draw_map
    from siku_io.plot.grid_maps import draw_grid_map

    # --profile: the run's wall time and where it goes (bench/RESULTS.md quotes it)
    _run(["siku", "run", "--no-plots", "--profile", "--set", f"time.duration={hours:g}h"], work)
    h5 = work / "siku_default.h5"
    tag = f"{hours:g}h"
    pics = [draw_map(h5, out / "default_damage_0h.png", 0, "damage"),
            draw_map(h5, out / f"default_damage_{tag}.png", -1, "damage")]
    cfg = GridCfg(kind="polar_stereographic", central_longitude=-155.0,
                  x=[-800000.0, 800000.0], y=[-2400000.0, -1200000.0], resolution=20000.0)
    grid = write_netcdf(grid_output(h5, cfg), work / "siku_default.grid.nc")
    pics.append(draw_grid_map(grid, out / f"default_grid_broken_joints_{tag}.png",
                              "broken_joints", -1))
    return pics


def case(work: Path, out: Path, hours: float) -> list[Path]:
    from siku_io.plot.element_maps import draw_map

    shutil.copytree(ROOT / "examples" / "case_studies", work / "case_studies",
                    ignore=shutil.ignore_patterns("ncep", "*.h5", "*.png", "*.gif"))
    folder = work / "case_studies"
    _run([sys.executable, "cases.py", "2001-04-06"], folder)
    _run(["siku", "run", "beaufort_2001-04-06.toml", "--no-plots", "--out", "case.h5",
          "--set", f"time.duration={hours:g}h"], folder)
    return [draw_map(folder / "case.h5", out / f"case_2001-04-06_standin_{hours:g}h.png", -1,
                     "damage")]


def waves(work: Path, out: Path, hours: float) -> list[Path]:
    _run([sys.executable, str(ROOT / "examples" / "waves" / "breaking.py"),
          str(out / "wave_breaking.png")], work)
    return [out / "wave_breaking.png"]


def two_way(work: Path, out: Path, hours: float) -> list[Path]:
    _run([sys.executable, str(ROOT / "examples" / "coupling" / "two_way_waves.py"),
          str(out / "two_way_waves.png")], work)
    return [out / "two_way_waves.png"]


def ice_life(work: Path, out: Path, hours: float) -> list[Path]:
    scene = ROOT / "examples" / "ice_life" / "cold_snap.toml"
    _run(["siku", "run", str(scene), "--no-progress", "--out", "cold_snap.h5", "--set",
          f"time.duration={hours:g}h"], work)
    _run([sys.executable, str(ROOT / "examples" / "ice_life" / "budget.py"), "cold_snap.h5",
          "pictures"], work)
    made = []
    for name, target in (("thickness_change.png", "ice_life_thickness_change.png"),
                         ("volume_budget.png", "ice_life_volume_budget.png")):
        made.append(Path(shutil.copyfile(work / "pictures" / name, out / target)))
    return made


def ice_edge(work: Path, out: Path, hours: float) -> list[Path]:
    _run([sys.executable, str(ROOT / "examples" / "miz" / "run.py"), "ice_edge.toml", "--out",
          str(work)], work)
    return [Path(shutil.copyfile(work / "ice_edge.png", out / "ice_edge.png"))]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python docs/gallery/make_gallery.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=NAMES, default=list(NAMES))
    ap.add_argument("--out", type=Path, default=HERE, help="folder for the pictures")
    ap.add_argument("--hours", type=float, default=24.0, help="model hours of the runs")
    ap.add_argument("--keep", type=Path, help="run in this new folder and keep the runs' "
                    "outputs there (e.g. siku_default.h5 for siku deformation)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out.resolve()
    steps = {"default": default, "case": case, "waves": waves, "two_way": two_way,
             "ice_life": ice_life, "ice_edge": ice_edge}
    with tempfile.TemporaryDirectory(prefix="siku_gallery_") as tmp:
        base = Path(tmp)
        if args.keep is not None:
            args.keep.mkdir(parents=True)  # a new folder: never one that holds other files
            base = args.keep.resolve()
        for name in args.only:
            work = base / name
            work.mkdir()
            for p in steps[name](work, out, args.hours):
                print("picture:", p, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
