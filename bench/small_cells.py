"""The smallest free cells of the default scene's mesh and the contacts' critical step, without
and with ``[elements.mesh] min_area_share`` (``siku_io.mesh.relax``).

``python -m bench.small_cells [SHARE ...]`` (default ``0.6``; from the repository root) builds the
shipped default scene's mesh with ``min_area_share = 0`` and each SHARE (the scene file is not
changed: the key is set with a scene override; the meshes go to ``$SIKU_CACHE_DIR/meshes``), and
prints per mesh the cells, the smallest free cell's and the 5th percentile's share of the median
free-cell area, the relaxation's work (seeds moved, pairs merged, rounds, build time), the cells
that differ from the mesh without relaxation, and the critical step of the run
(``Simulation(...).critical_dt``, with the component that sets it) against the scene's ``dt``.
A build takes about 20 s on one core, the elements and contacts of a run about a minute.
"""
from __future__ import annotations

import sys
import time

import numpy as np


def _cell_keys(mesh) -> set[bytes]:
    """Each cell's vertices (rounded to 1e-9 degrees) as bytes: equal keys, the same cell."""
    ll = np.round(mesh.lonlat, 9)
    return {ll[a:b].tobytes() for a, b in zip(mesh.offsets[:-1], mesh.offsets[1:])}


def measure(share: float) -> dict:
    """Mesh and run of the default scene with ``min_area_share = share``."""
    from siku_core.scene.cells import small_cell_report
    from siku_core.run.cli import default_scene_path
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation
    from siku_core.state import FREE
    from siku_io.mesh.cache import mesh_for_scene

    over = {"elements.mesh.min_area_share": repr(float(share)), "time.duration": '"10min"'}
    scene = load_scene(default_scene_path(), over)
    t0 = time.perf_counter()
    mesh, _ = mesh_for_scene(scene)
    t_mesh = time.perf_counter() - t0
    sim = Simulation(scene, out=False, progress=False)
    st = sim.state
    rep = small_cell_report(st.area, st.flags)
    return {"share": share, "mesh": mesh, "cells": mesh.n, "free": int(np.sum(st.flags == FREE)),
            "elements": st.n, "report": rep, "relaxed": mesh.stats.get("relaxed"),
            "critical_dt": float(sim.critical_dt), "dt": float(sim.dt), "mesh_s": t_mesh}


def main(argv: list[str] | None = None) -> int:
    shares = [float(a) for a in (sys.argv[1:] if argv is None else argv)] or [0.6]
    rows = [measure(s) for s in [0.0, *shares]]
    base = _cell_keys(rows[0]["mesh"])
    print("| min_area_share | elements (free) | smallest / median | 5th pct / median | "
          "step factor | seeds moved, pairs merged, rounds | cells changed | critical dt |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        rep, x = r["report"], r["relaxed"]
        work = (f"{x['moved']}, {x['merged']}, {x['rounds']} ({x['seconds']:.1f} s)" if x
                else "—")
        changed = len(_cell_keys(r["mesh"]) - base)
        print(f"| {r['share']:g} | {r['elements']} ({r['free']}) | {rep.smallest:.3f} | "
              f"{rep.p5:.3f} | {rep.step_factor:.3f} | {work} | {changed} | "
              f"{r['critical_dt']:.4g} s (dt {r['dt']:g} s) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
