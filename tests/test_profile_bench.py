"""``siku run --profile`` / ``--threads``, ``Simulation.timings``, and the benchmark runner
(``siku bench`` forwards to ``python -m bench``); a tiny benchmark run as a smoke test, with no
assertion on times."""
from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import numba
import pytest

from siku_core.run.cli import main
from siku_core.run.simulation import PHASES, Simulation
from siku_core.testing.contact_conformance import contact_scene_text, square_pack

ROOT = Path(__file__).resolve().parents[1]
WIND = {"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}}


def scene_text():
    pack = square_pack(0.0, -1.0, 6, 4, 20000.0, left="static", right="steady",
                       right_velocity=[3.0, 0.0])
    return contact_scene_text("distributed_spring", {"tensile_strain": 0.05}, packs=[pack],
                              dt=2.0, steps=20, forcing=[WIND])


def test_timings_cover_every_phase_of_the_step():
    from siku_core.scene.scene_file import scene_from_text

    sim = Simulation(scene_from_text(scene_text()), out=False, progress=False).run()
    assert set(sim.timings) == set(PHASES)
    assert sim.timed_steps == 20
    for phase in ("forcing", "joints", "broad_phase", "collisions", "contact_sum", "integrator",
                  "guard"):
        assert sim.timings[phase] > 0.0, phase
    assert [k for k, _ in sim.profile()] == [k for k in PHASES if sim.timings[k] > 0]
    sim.reset_timings()
    assert not any(sim.timings.values()) and sim.timed_steps == 0


def test_run_profile_prints_the_phases(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(scene_text(), encoding="utf-8")
    assert main(["run", "s.toml", "--no-progress", "--profile", "--threads", "1",
                 "--out", "o.h5", "--no-plots"]) == 0
    err = capsys.readouterr().err
    assert "profile: 20 steps of 24 elements" in err and "1 thread(s)" in err
    for phase in ("forcing", "joints", "broad_phase", "collisions", "contact_sum",
                  "integrator", "guard", "output", "other"):
        assert f"\n  {phase} " in err, phase
    by_hour = err.split("profile by hour of model time")[1].splitlines()
    assert by_hour[2].split()[:2] == ["0-0.0111", "20"]  # 20 steps of 2 s, under one hour


def test_phase_log_splits_the_timings_by_window_of_model_time():
    from siku_core.run.phase_log import PhaseLog
    from siku_core.scene.scene_file import scene_from_text

    sim = Simulation(scene_from_text(scene_text()), out=False, progress=False)
    cpu0 = time.process_time()  # the process's CPU over the windows' whole span
    sim.phase_log = PhaseLog(sim, every=10.0)  # 20 steps of 2 s: four windows of five steps
    sim.run()
    log = sim.phase_log
    assert len(log.windows) == 3  # the fourth closes after the run (its last output)
    log.finish(sim)
    log.finish(sim)  # nothing under way: no fifth window
    cpu_run = time.process_time() - cpu0
    assert [(w.start, w.end, w.steps) for w in log.windows] == [
        (10.0 * k, 10.0 * (k + 1), 5) for k in range(4)]
    for phase in PHASES:  # the windows add up to the run's timers
        assert sum(w.phases[phase] for w in log.windows) == pytest.approx(
            sim.timings[phase], rel=1e-9, abs=1e-12), phase
    for w in log.windows:
        assert w.wall >= sum(w.phases.values()) - 1e-9
        assert w.contacts["pairs"] == len(sim.contacts.pairs)
    assert log.windows[-1].contacts["n_broken_total"] == sim.contacts.n_broken_total
    # the windows' CPU time is the process's, split: each window's is positive (it steps) and
    # together they are no more than the process's over the same span (from the log's start to
    # its last window's close: other threads' CPU counts in both, compiling in neither)
    assert all(w.cpu > 0.0 for w in log.windows)
    assert sum(w.cpu for w in log.windows) <= cpu_run + 1e-3
    assert all(math.isfinite(w.load) and w.load >= 0.0 for w in log.windows)  # Linux tells
    table = log.table(sim.state.n, PHASES).splitlines()
    assert len(table) == 2 + 4 and table[2].split()[:2] == ["0-0.00278", "5"]
    head = table[1].split()
    assert head[2:5] == ["steps/s", "el-steps/s", "CPU"] and head[-1] == "load"
    for w, row in zip(log.windows, table[2:]):  # steps/s is the steps over the wall time
        cells = row.split()
        assert float(cells[2]) == pytest.approx(w.steps / w.wall, rel=1e-3)
        assert float(cells[3]) == pytest.approx(sim.state.n * w.steps / w.wall, rel=5e-3)
        assert float(cells[4]) == pytest.approx(1e3 * w.cpu / w.steps, abs=1e-3)
        assert float(cells[-1]) == pytest.approx(w.load, abs=0.01)
    with pytest.raises(ValueError):
        PhaseLog(sim, every=0.0)


def test_threads_out_of_range_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(scene_text(), encoding="utf-8")
    assert main(["run", "s.toml", "--no-progress", "--threads", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("siku: error: --threads 0: choose 1 to ")
    assert numba.get_num_threads() >= 1


def test_siku_bench_forwards_to_the_runner(capfd):
    assert main(["bench", "--help"]) == 0
    assert "python -m bench" in capfd.readouterr().out
    assert main(["bench", "--scenes", "nowhere"]) == 2


@pytest.mark.skipif(not (ROOT / "bench" / "__main__.py").is_file(), reason="no bench/")
def test_a_tiny_benchmark_runs():
    r = subprocess.run(
        [sys.executable, "-m", "bench", "--sizes", "120", "--laws", "distributed_spring",
         "--steps", "3", "--threads", "1"],
        cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    for row in ("| bonded | distributed_spring | 120 |", "| collision | collision | 120 |",
                "| free_drift | - | 120 |", "only what a scene requires"):
        assert row in out, row
    # the floe runs Orzech et al.'s law and, on the same elements and joints, the law asked for
    for row in ("| floe | bonded_particle |", "| floe | distributed_spring |"):
        assert row in out, row
    assert "I/O libraries imported after building and running both scenes: none" in out


@pytest.mark.skipif(not (ROOT / "bench" / "phase.py").is_file(), reason="no bench/")
def test_the_phase_probe_times_the_pack_it_builds():
    """``bench.phase``: on a bonded pack of nx x ny squares every shared edge is a joint,
    ``(nx - 1) ny + nx (ny - 1)``, except the ``ny - 1`` inside the static west column and
    the ``ny - 1`` inside the steady east one (elements that are not free never interact with
    each other), and the candidate pairs are the joints' and the diagonal neighbours,
    ``2 (nx - 1)(ny - 1)`` more; a scene without contacts is bad input (2)."""
    sys.path.insert(0, str(ROOT))
    try:
        from bench import phase
        from bench.scenes import grid
    finally:
        sys.path.remove(str(ROOT))
    nx, ny = grid(120)
    r = phase.measure("bonded", 120, "distributed_spring", 2, 1)
    assert r["elements"] == nx * ny
    assert r["joints"] == (nx - 1) * ny + nx * (ny - 1) - 2 * (ny - 1)
    assert r["pairs"] == r["joints"] + 2 * (nx - 1) * (ny - 1)
    assert 0 <= r["overlapping"] <= r["pairs"]
    assert r["collisions_s"] > 0 and r["joints_s"] > 0
    assert "ns/pair" in phase.report("bonded", "distributed_spring", r)
    assert phase.main(["free_drift", "--elements", "120", "--reps", "1"]) == 2


def _peers():
    sys.path.insert(0, str(ROOT))
    try:
        from bench import peers
    finally:
        sys.path.remove(str(ROOT))
    return peers


@pytest.mark.skipif(not (ROOT / "bench" / "peers.py").is_file(), reason="no bench/")
def test_peer_table_ratios_are_best_against_best():
    peers = _peers()
    lmp = [{"lattice": "sq", "ranks": t, "atoms": 10000, "bonds": 19800, "rate": r}
           for t, r in ((1, 2.0e6), (1, 2.5e6), (2, 4.0e6))]
    siku = [{"lattice": "sq", "kind": "bonded", "law": "distributed_spring", "threads": t,
             "elements": 10000, "joints": 19800, "rate": r}
            for t, r in ((1, 3.0e6), (1, 3.75e6), (2, 2.0e6))]
    rows = peers.table(lmp, siku, [1, 2]).splitlines()
    row = next(x for x in rows if "siku `bonded`" in x)
    cells = [c.strip() for c in row.strip("|").split("|")]
    # best 3.75e6 over LAMMPS's best 2.5e6; median of (3.0, 3.75)e6 in brackets
    assert cells[4] == "3.75e6 (3.38e6)"
    assert cells[-2:] == ["1.50", "0.50"]
    assert cells[3] == "1.98"


@pytest.mark.skipif(not (ROOT / "bench" / "peers.py").is_file(), reason="no bench/")
def test_peer_lattices_have_the_packs_topology(tmp_path):
    peers = _peers()
    exe = peers.find_lammps()
    if exe is None:
        pytest.skip("LAMMPS not installed (optional extra [peers])")
    # 100 × 100 square lattice: 2 · 100 · 99 nearest-neighbour bonds; 100 rows of 100 on the
    # triangular one: 100 · 99 along the rows and 2 · 100 − 1 between each of the 99 row pairs
    for lattice, bonds in (("sq", 19800), ("hex", 100 * 99 + 99 * 199)):
        r = peers.run_lammps(*exe, lattice, 1, 5, tmp_path)
        assert (r["atoms"], r["bonds"], r["steps"]) == (10000, bonds, 5)
        assert r["rate"] > 0.0


def test_every_benchmark_scene_is_a_valid_scene_with_its_options():
    """The runner's scene list is ``bench.scenes.KINDS``; each kind validates, and the
    ``_ignore`` / ``_exclude`` kinds set exactly their ``[contact]`` option."""
    sys.path.insert(0, str(ROOT))
    try:
        from bench.__main__ import KINDS as RUNNER_KINDS
        from bench.scenes import KINDS, scene
    finally:
        sys.path.remove(str(ROOT))
    assert RUNNER_KINDS == KINDS
    for kind in KINDS:
        cfg = scene(kind, 200).cfg
        if kind == "free_drift":
            assert cfg.contact is None
            continue
        # the collision scene keeps the engine's default rule (its pairs overlap for real:
        # either rule finds the same contacts); the packs state theirs
        want = "ignore" if kind.endswith("_ignore") or kind == "collision" else "contact"
        assert cfg.contact.touching == want
        assert cfg.contact.jointed == ("exclude" if kind.endswith("_exclude") else "collide")
