"""One scene on MPI ranks gives the bits of one rank (docs/explanation/scaling_out.md).

The runs on ranks are real ``mpiexec -n N`` processes (the ``mpich`` wheel's launcher), each
under a timeout that turns a deadlock into a failure; the run on one rank is the plain
``Simulation`` in this process. Cases (``siku_core.testing.ranks_cases``): a bonded pack whose
joints break with the ranks' boundary across the breaking joints, the pack with
``mohr_coulomb``, a collision pack, elements moving to the other rank and back; ``siku run
--ranks 2`` writes the same output file byte for byte, and a restart from it runs on one rank;
a rank raising ends the run with one line; a different scene on one rank is refused; the
pack pulled apart under ``thermodynamics``, ``ridging`` and ``refreeze`` (joints across the
boundary break and refreeze, pairs across it ridge, elements change rank and back); a pack
pressed together under ``refreeze`` with ``weld = true`` (pairs across the boundary weld into
new joints, numbered as one rank numbers them, which break and refreeze).
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from siku_core.ranks import launched_rank, launched_ranks, mpiexec
from siku_core.ranks.decompose import bisect, imbalance
from siku_core.ranks.ghosts import exchange_plan, local_sets

try:
    import mpi4py  # noqa: F401
    HAVE_MPI = mpiexec() is not None
except ImportError:
    HAVE_MPI = False

needs_mpi = pytest.mark.skipif(not HAVE_MPI, reason="mpi4py and mpiexec not installed "
                               "(pip install 'siku[mpi]')")
ROOT = Path(__file__).resolve().parents[1]
#: a deadlock becomes a failure after this many seconds [s]
TIMEOUT = 240
CASES = ("spring", "mohr", "collision", "migrate", "rebalance")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.setdefault("NUMBA_NUM_THREADS", "1")
    for k in ("PMI_SIZE", "PMI_RANK", "OMPI_COMM_WORLD_SIZE", "PMIX_SIZE"):
        env.pop(k, None)
    return env


def cli_scene(folder: Path, text: str, output: str, name: str = "scene.toml"):
    """Write the scene ``text`` with the ``[output]`` keys ``output`` into ``folder``, run it
    once and on two ranks (``siku run --ranks 2``), assert that the two write the same bytes,
    and return ``run(OUT, *ARGS)``, which runs it again in ``folder`` (a hang fails)."""
    (folder / name).write_text(text.replace("[run]", f"[output]\n{output}\n\n[run]"),
                               encoding="utf-8")
    base = [sys.executable, "-m", "siku_core.run.cli", "run", name, "--no-progress",
            "--no-plots", "--out"]

    def run(*args):
        p = subprocess.run([*base, *args], cwd=folder, env=_env(), capture_output=True,
                           text=True, timeout=TIMEOUT)
        assert p.returncode == 0, p.stderr
    run("one.h5")
    run("two.h5", "--ranks", "2")
    assert (folder / "one.h5").read_bytes() == (folder / "two.h5").read_bytes()
    return run


def mpirun(n: int, args: list[str], cwd: Path, timeout: int = TIMEOUT):
    """``mpiexec -n n python ARGS`` in ``cwd``: (exit status, stderr); a hang fails."""
    cmd = [mpiexec(), "-n", str(n), sys.executable, *args]
    try:
        p = subprocess.run(cmd, cwd=cwd, env=_env(), capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{' '.join(cmd)} did not finish in {timeout} s (a deadlock?)")
    return p.returncode, p.stderr


def run_cases(n: int, folder: Path, names) -> Path:
    """The ranks cases ``names`` (``siku_core.testing.ranks_cases``) on ``n`` ranks, each
    writing ``folder/<name>.npz``; a failure or a hang (each case's timeout) fails the test."""
    rc, err = mpirun(n, ["-m", "siku_core.testing.ranks_cases", str(folder), *names], folder,
                     timeout=TIMEOUT * len(names))
    assert rc == 0, err
    return folder


def one_rank(name: str) -> dict[str, np.ndarray]:
    from siku_core.testing.ranks_cases import run_case

    return run_case(name, ranks=False)


def assert_same_bits(one: dict, many, name: str) -> None:
    keys = [k for k in one if not k.startswith("ranks_")]
    assert sorted(keys) == sorted(k for k in many.files if not k.startswith("ranks_")), name
    differ = [k for k in keys if np.asarray(one[k]).tobytes() != many[k].tobytes()
              or np.asarray(one[k]).dtype != many[k].dtype]
    assert not differ, f"{name}: differ on ranks: {differ}"


@pytest.fixture(scope="module")
def two_ranks(tmp_path_factory):
    if not HAVE_MPI:
        pytest.skip("mpi4py and mpiexec not installed (pip install 'siku[mpi]')")
    return run_cases(2, tmp_path_factory.mktemp("ranks2"), CASES)


# ---------------------------------------------------------------------- the same bits
@needs_mpi
@pytest.mark.parametrize("name", CASES)
def test_two_ranks_same_bits(two_ranks, name):
    """Final state, joints, diagnostics and per-element fields equal one rank's bit for
    bit; every joint held by both ranks is in the same state on both."""
    many = np.load(two_ranks / f"{name}.npz")
    one = one_rank(name)
    assert_same_bits(one, many, name)
    assert bool(many["ranks_joints_agree"])
    if name == "spring":  # the breaking joints cross the ranks' boundary, and do break
        assert int(many["ranks_shared_joints"]) >= 2
        assert int(one["n_broken_total"]) >= 2
        assert int(np.count_nonzero(~one["joint_intact"])) == int(one["n_broken_total"])
    if name in ("collision", "rebalance"):
        assert int(one["diag_contacts_overlapping"]) > 0
    if name == "migrate":  # each of the 10 elements changed rank at steps 60, 120, ... 540
        assert int(many["ranks_migrated"]) >= 9 * 10
    if name == "rebalance":  # split again as the measured work varied
        assert int(many["ranks_splits"]) >= 3


@needs_mpi
def test_thermodynamics_on_two_ranks_same_bits(tmp_path):
    """The bonded pack thinning and melting away under ``thermodynamics``, the ranks'
    boundary across joints: thickness, mass, flags, the process's fields, joints broken by
    the melt and diagnostics equal one rank's bit for bit."""
    rc, err = mpirun(2, ["-m", "siku_core.testing.ranks_cases", str(tmp_path), "thermo"],
                     tmp_path)
    assert rc == 0, err
    many = np.load(tmp_path / "thermo.npz")
    one = one_rank("thermo")
    assert_same_bits(one, many, "thermo")
    assert bool(many["ranks_joints_agree"])
    assert int(many["ranks_shared_joints"]) >= 2
    h0 = 1.0  # the pack's thickness [m]: it thinned, then every element melted away
    assert (one["field_flags"] == 3).all() and (one["field_thickness"] < 0.1 * h0).all()
    assert int(one["diag_joints_broken_melt"]) == len(one["joint_intact"])
    assert (one["field_grown_volume"] < 0).all()


@needs_mpi
@pytest.mark.slow
def test_thermodynamics_writes_the_same_file_on_two_ranks_and_restarts_on_one(tmp_path):
    """``siku run --ranks 2`` of the thinning pack writes the one-rank file byte for byte
    (thickness, mass, flags, the process's fields and diagnostics); a restart from its
    mid-run snapshot on one rank writes what the one-rank run writes."""
    from siku_core.testing.ranks_cases import thermo_text

    (tmp_path / "scene.toml").write_text(thermo_text(flux=3e6).replace(
        "[run]", '[output]\nevery = 20.0\ndiagnostics_every = 3.0\n\n[run]'),
        encoding="utf-8")
    base = [sys.executable, "-m", "siku_core.run.cli", "run", "scene.toml", "--no-progress",
            "--no-plots", "--out"]

    def run(*args):
        p = subprocess.run([*base, *args], cwd=tmp_path, env=_env(), capture_output=True,
                           text=True, timeout=TIMEOUT)
        assert p.returncode == 0, p.stderr
    run("one.h5")
    run("two.h5", "--ranks", "2")
    one = (tmp_path / "one.h5").read_bytes()
    assert one == (tmp_path / "two.h5").read_bytes()
    run("part.h5", "--ranks", "2", "--set", "time.duration=40s")
    run("more.h5", "--restart", "part.h5", "--set", "time.duration=40s", "--extend", "20s")
    import h5py

    with h5py.File(tmp_path / "one.h5", "r") as a, h5py.File(tmp_path / "more.h5", "r") as b:
        k = list(a["states/step"][:]).index(int(b["states/step"][-1]))
        for name in ("fields/thickness", "fields/grown_volume", "fields/flags", "q", "V"):
            assert np.array_equal(a[f"states/{name}"][k], b[f"states/{name}"][-1]), name


@needs_mpi
def test_cli_ranks_writes_the_same_file_and_restarts_on_one(tmp_path):
    """``siku run --ranks 2`` writes the file one rank writes, byte for byte; a restart
    from it continues on one rank exactly as from the one-rank file, and a restart on two
    ranks writes the same file again."""
    from siku_core.run.cli import main
    from siku_core.testing.ranks_cases import spring_text

    (tmp_path / "scene.toml").write_text(spring_text(3000).replace(
        "[run]", '[output]\nevery = 2.0\ndiagnostics_every = 0.7\n\n[run]'), encoding="utf-8")
    base = ["run", "scene.toml", "--no-progress", "--no-plots"]
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main([*base, "--out", "one.h5"]) == 0
        p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", *base, "--out", "two.h5",
                            "--ranks", "2", "--profile"], env=_env(), capture_output=True,
                           text=True, timeout=TIMEOUT)
        assert p.returncode == 0, p.stderr
        assert "on 2 MPI ranks" in p.stderr
        _check_profile_on_ranks(p.stderr, steps=3000, ranks=2, n=10)
        assert (tmp_path / "one.h5").read_bytes() == (tmp_path / "two.h5").read_bytes()
        for f in ("one", "two"):
            assert main([*base, "--restart", f"{f}.h5", "--extend", "20s",
                         "--out", f"{f}_more.h5"]) == 0
        p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", *base, "--restart",
                            "one.h5", "--extend", "20s", "--out", "ranks_more.h5", "--ranks",
                            "2"], env=_env(), capture_output=True, text=True, timeout=TIMEOUT)
        assert p.returncode == 0, p.stderr
    finally:
        os.chdir(cwd)
    import h5py

    with h5py.File(tmp_path / "one.h5") as f:
        assert len(f["breaks/joint"]) >= 2  # the file holds breaks found on ranks
    a = (tmp_path / "one_more.h5").read_bytes()
    assert a == (tmp_path / "two_more.h5").read_bytes()
    assert a == (tmp_path / "ranks_more.h5").read_bytes()  # and a restart on two ranks


def _check_profile_on_ranks(err: str, steps: int, ranks: int, n: int) -> None:
    """``siku run --profile`` on ranks: rank 0's phases over its steps (the exchange among
    them), then a row per rank whose steps are the run's, its elements add up to the run's
    and whose exchange is a share of its stepping time."""
    lines = err.splitlines()
    head = next(ln for ln in lines if ln.startswith("profile: "))
    assert head.startswith(f"profile: {steps} steps of rank 0's "), head
    assert any(ln.split()[:1] == ["exchange"] for ln in lines), err
    at = next(k for k, ln in enumerate(lines) if ln.startswith(f"ranks: {ranks} "))
    rows = [ln.split() for ln in lines[at + 2:at + 2 + ranks]]
    assert [int(r[0]) for r in rows] == list(range(ranks)), err
    assert sum(int(r[1]) for r in rows) == n  # each element owned by one rank
    assert all(int(r[3]) == steps for r in rows), err
    for r in rows:  # busy and exchange seconds, the exchange's share of the steps' time
        assert float(r[4]) > 0.0 and float(r[5]) > 0.0
        assert 0.0 < float(r[6].rstrip("%")) <= 100.0


RIDGE_FREEZE = ("ridge_freeze", "ridge_freeze_split", "ridge_freeze_migrate")


@pytest.fixture(scope="module")
def ridge_freeze_ranks(tmp_path_factory):
    if not HAVE_MPI:
        pytest.skip("mpi4py and mpiexec not installed (pip install 'siku[mpi]')")
    return run_cases(2, tmp_path_factory.mktemp("ridge_freeze"), (*RIDGE_FREEZE, "weld"))


@needs_mpi
@pytest.mark.parametrize("name", RIDGE_FREEZE)
def test_ridging_and_refreeze_on_two_ranks_same_bits(ridge_freeze_ranks, name):
    """Thermodynamics, ridging and refreezing on two ranks: state, thickness, the processes'
    fields and history (ridging pairs, refreeze times and count), every joint's state
    (broken by the law and by the refrozen strength, refrozen where it stood) and the
    diagnostics equal one rank's bit for bit; a joint shared by the ranks is in the same state
    on both. Ranks split by column (the refreezing joints across the boundary), by bisection,
    and every element changing rank every 60 steps (history carried there and back)."""
    many = np.load(ridge_freeze_ranks / f"{name}.npz")
    one = one_rank(name)
    assert_same_bits(one, many, name)
    assert bool(many["ranks_joints_agree"])
    # the scene does what it is for: joints break, refreeze and break again, pairs ridge
    assert int(one["diag_refrozen_joints"]) >= 2
    assert int(one["diag_joints_broken_tension"]) >= 1  # a refrozen joint broke again
    assert int(one["n_broken_total"]) > int(one["diag_refrozen_joints"])
    assert float(one["field_ridged_volume"].sum()) > 0.0
    if name == "ridge_freeze":  # the refreezing joints cross the ranks' boundary
        assert int(many["ranks_shared_joints"]) >= 2
    if name == "ridge_freeze_split":  # a ridging pair across the boundary
        assert int(many["ranks_shared_pairs"]) >= 1
    if name == "ridge_freeze_migrate":  # each element changed rank at steps 60 ... 480
        assert int(many["ranks_migrated"]) >= 8 * 10


def assert_welds_across(one: dict, many, ranks: int) -> None:
    """The weld case does what it is for: pairs weld (some between elements that different
    ranks own), welded joints break under their growing strength, broken ones refreeze."""
    assert int(one["diag_welded_joints"]) >= 10
    assert int(many["ranks_welded_across"]) >= 1, ranks
    assert int(one["diag_joints_broken_tension"]) >= 1
    assert int(one["diag_refrozen_joints"]) >= 1
    # every joint of the scene was welded: the joint table is the welds', in the run's order
    assert len(one["joint_ji"]) == int(one["diag_welded_joints"])


@needs_mpi
def test_weld_on_two_ranks_same_bits(ridge_freeze_ranks):
    """``refreeze`` with ``weld = true`` on two ranks (split by bisection, redistributed every
    25 steps): pairs in contact weld into new joints, numbered in the run's joint table as one
    rank numbers them, across the ranks' boundary too; they break and refreeze. The joint
    table (elements, lines, rest state, breaks), the process's history (its clocks per joint,
    the pairs it follows and its counts), the state and the diagnostics and fields at every
    diagnostics step equal one rank's bit for bit."""
    many = np.load(ridge_freeze_ranks / "weld.npz")
    one = one_rank("weld")
    assert_same_bits(one, many, "weld")
    assert bool(many["ranks_joints_agree"])
    assert_welds_across(one, many, 2)


@needs_mpi
@pytest.mark.slow
def test_ridging_and_refreeze_write_the_same_file_on_two_ranks_and_restart(tmp_path):
    """``siku run --ranks 2`` of the pack under thermodynamics, ridging and refreezing writes
    the one-rank file byte for byte (state, joints, breaks, the processes' fields, history and
    diagnostics); a snapshot written on two ranks continues on one, and one written on one
    continues on two, as the one-rank run does."""
    import h5py

    from siku_core.testing.ranks_cases import ridge_freeze_text

    run = cli_scene(tmp_path, ridge_freeze_text(500), "every = 10.0\ndiagnostics_every = 3.0")
    half = ["--set", "time.duration=30s"]
    run("part2.h5", "--ranks", "2", *half)
    run("part1.h5", *half)
    run("more1.h5", "--restart", "part2.h5", *half, "--extend", "20s")
    run("more2.h5", "--restart", "part1.h5", *half, "--extend", "20s", "--ranks", "2")
    with h5py.File(tmp_path / "one.h5", "r") as a:
        for name in ("more1.h5", "more2.h5"):
            with h5py.File(tmp_path / name, "r") as b:
                k = list(a["states/step"][:]).index(int(b["states/step"][-1]))
                for f in ("fields/thickness", "fields/ridged_volume", "q", "V"):
                    assert np.array_equal(a[f"states/{f}"][k], b[f"states/{f}"][-1]), (name, f)
                assert np.array_equal(a["diagnostics/refrozen_joints"][-1],
                                      b["diagnostics/refrozen_joints"][-1]), name


@needs_mpi
@pytest.mark.slow
def test_weld_writes_the_same_file_on_two_ranks_and_restarts_on_one_and_three(tmp_path):
    """``refreeze`` with ``weld = true``: ``siku run --ranks 2`` writes the one-rank file
    byte for byte (the created joints, their lines and rest state, the pairs followed); a
    restart written halfway on two ranks continues on one, one written on one rank continues
    on three, and both end where the uninterrupted run does."""
    import h5py

    from siku_core.testing.ranks_cases import weld_text

    run = cli_scene(tmp_path, weld_text(200), "every = 2.0\ndiagnostics_every = 1.0")
    half = ["--set", "time.duration=10s"]
    run("part2.h5", "--ranks", "2", *half)
    run("part1.h5", *half)
    run("more1.h5", "--restart", "part2.h5", *half, "--extend", "10s")
    run("more3.h5", "--restart", "part1.h5", *half, "--extend", "10s", "--ranks", "3")
    with h5py.File(tmp_path / "one.h5", "r") as a:
        assert a["diagnostics/welded_joints"][-1] >= 10
        for name in ("more1.h5", "more3.h5"):
            with h5py.File(tmp_path / name, "r") as b:
                assert int(b["states/step"][-1]) == int(a["states/step"][-1])
                for f in ("q", "V", "w"):
                    assert np.array_equal(a[f"states/{f}"][-1], b[f"states/{f}"][-1]), (name, f)
                for d in ("welded_joints", "refrozen_joints", "joints_intact"):
                    assert np.array_equal(a[f"diagnostics/{d}"][-1],
                                          b[f"diagnostics/{d}"][-1]), (name, d)


# ---------------------------------------------------------------------- faults, refusals
@needs_mpi
def test_a_rank_raising_ends_the_run_with_one_line(tmp_path):
    rc, err = mpirun(2, ["-m", "siku_core.testing.ranks_cases", str(tmp_path), "raise"],
                     tmp_path, timeout=120)
    assert rc != 0
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert lines == ["siku: error: rank 1: RuntimeError: integrator failed on purpose"], err
    assert "Traceback" not in err
    assert not (tmp_path / "raise.npz").exists()


@needs_mpi
def test_ranks_given_different_scenes_or_a_process_are_refused(tmp_path):
    from siku_core.testing.ranks_cases import spring_text

    (tmp_path / "a.toml").write_text(spring_text(50), encoding="utf-8")
    (tmp_path / "b.toml").write_text(spring_text(50).replace("tensile_strain = 0.0002",
                                                             "tensile_strain = 0.0003"),
                                     encoding="utf-8")
    run = [sys.executable, "-m", "siku_core.run.cli", "run", "--no-progress", "--no-plots",
           "--out"]
    cmd = [mpiexec(), "-n", "1", *run, "x.h5", "a.toml", ":", "-n", "1", *run, "x.h5",
           "b.toml"]
    p = subprocess.run(cmd, cwd=tmp_path, env=_env(), capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 2, p.stderr
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("siku: error:")]
    assert len(lines) == 1 and "rank 1 was given a different scene" in lines[0], p.stderr
    assert not (tmp_path / "x.h5").exists()
    # a component that cannot run on ranks: refused in one line naming it and the ranks
    (tmp_path / "c.toml").write_text(spring_text(50) + EXCHANGE, encoding="utf-8")
    p = subprocess.run([*run, "y.h5", "c.toml", "--ranks", "2"], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=120)
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("siku: error:")]
    assert p.returncode == 2 and len(lines) == 1, p.stderr
    assert "forcing 'exchange' cannot run on 2 ranks" in lines[0], lines[0]
    assert not (tmp_path / "y.h5").exists()


#: the coupling's exchange forcing over the spring pack (its coupled model exchanges fields
#: with one process: it cannot run on ranks)
EXCHANGE = """
[[forcing]]
source = "exchange"

[coupling.grid]
kind = "lonlat"
lon = [29.8, 30.5]
lat = [71.9, 72.2]
resolution = 0.05
"""


def test_components_that_cannot_run_on_ranks_are_named():
    """A scene with a component that cannot run on ranks (the coupling's exchange forcing, a
    process keeping history without saying how ranks split it) is refused on ranks in one
    line naming it and the ranks; forcing, integrator, contact law, thermodynamics, ridging,
    refreezing and welding are not."""
    from siku_core.ranks.driver import refusals
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing.ranks_cases import spring_text

    plain = Simulation(scene_from_text(spring_text(10), "<a>"), out=False)
    assert refusals(plain, 2) == []
    from siku_core.testing.ranks_cases import ridge_freeze_text

    thermo = spring_text(10) + '\n[[process]]\nname = "thermodynamics"\n'
    assert refusals(Simulation(scene_from_text(thermo, "<t>"), out=False), 2) == []
    both = Simulation(scene_from_text(ridge_freeze_text(10), "<r>"), out=False)
    assert refusals(both, 3) == []
    weld = spring_text(10) + '\n[[process]]\nname = "refreeze"\nparams = { weld = true }\n'
    assert refusals(Simulation(scene_from_text(weld, "<w>"), out=False), 3) == []
    coupled = Simulation(scene_from_text(spring_text(10) + EXCHANGE, "<x>"), out=False)
    got = refusals(coupled, 3)
    assert len(got) == 1 and "forcing 'exchange' cannot run on 3 ranks" in got[0], got
    assert "exchanges fields with one process" in got[0]
    # a history without its layout: each rank's copy would keep its own part
    proc = both.processes[1]
    layout = type(proc).rank_history
    try:
        type(proc).rank_history = {k: v for k, v in layout.items() if k != "converted"}
        got = refusals(both, 2)
    finally:
        type(proc).rank_history = layout
    assert len(got) == 1 and "process 'ridging' cannot run on 2 ranks" in got[0], got
    assert "converted" in got[0]


# ---------------------------------------------------------------------- the parts
def test_bisection_balances_weights_and_is_deterministic():
    rng = np.random.default_rng(4)
    c = rng.normal(size=(1000, 3))
    c /= np.linalg.norm(c, axis=1)[:, None]
    w = rng.uniform(1.0, 3.0, 1000)
    for k in (2, 3, 4, 7):
        owner = bisect(c, w, k).assign(c)
        assert np.array_equal(owner, bisect(c, w, k).assign(c))
        load = np.bincount(owner, weights=w, minlength=k)
        # each cut is off its share by at most one element's weight per level
        levels = int(np.ceil(np.log2(k)))
        assert imbalance(load) <= levels * w.max() * k / w.sum() + 1e-12
    assert imbalance(np.array([1.0, 1.0])) == 0.0


def test_ghosts_hold_every_partner_and_the_plan_is_symmetric():
    owner = np.array([0, 0, 1, 1, 2])
    pairs = np.array([[0, 2], [1, 4], [3, 4]])
    held = local_sets(owner, 3, [pairs])
    assert [h.tolist() for h in held] == [[0, 1, 2, 4], [0, 2, 3, 4], [1, 3, 4]]
    # a second layer: the partners of the ghosts too (rank 0 holds 3, a partner of 4)
    assert [h.tolist() for h in local_sets(owner, 3, [pairs], depth=2)] == [
        [0, 1, 2, 3, 4], [0, 1, 2, 3, 4], [1, 3, 4]]
    plans = [exchange_plan(owner, held, r) for r in range(3)]
    for r in range(3):
        for s in range(3):
            assert np.array_equal(plans[r][0][s], plans[s][1][r])  # sent = received


def test_launch_is_read_from_the_environment_only():
    assert launched_ranks({}) == 1 and launched_rank({}) == 0
    assert launched_ranks({"PMI_SIZE": "4", "PMI_RANK": "3"}) == 4
    assert launched_rank({"PMI_SIZE": "4", "PMI_RANK": "3"}) == 3
    code = ("import sys, siku_core.run.simulation, siku_core.run.cli; "
            "sys.exit('mpi4py' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], env=_env(), timeout=120).returncode == 0


@needs_mpi
@pytest.mark.slow
def test_three_ranks_same_bits(tmp_path):
    """Three ranks: the spring pack and the collision pack, the spring pack under RK4
    with the breaking joints between ranks 1 and 2, beyond rank 0's ghosts (a later force
    evaluation of the step needs the ghosts' stage states and damper bounds), and the pack
    under thermodynamics, ridging and refreezing split by bisection."""
    names = ("spring", "collision", "rk4", "ridge_freeze_split", "weld")
    run_cases(3, tmp_path, names)
    for name in names:
        assert_same_bits(one_rank(name), np.load(tmp_path / f"{name}.npz"), name)
    assert_welds_across(one_rank("weld"), np.load(tmp_path / "weld.npz"), 3)


@needs_mpi
@pytest.mark.slow
def test_four_ranks_same_bits(tmp_path):
    """Four ranks (oversubscribed here): the collision pack split by bisection; the spring
    pack to its joints' breaks, every element moving to the next rank every 60 steps (the
    breaking joints always across two ranks); and the pack under thermodynamics, ridging
    and refreezing split by bisection (a ridging pair's giver a ghost whose other pairs reach
    beyond the first layer of ghosts); six elements in a ``spectral`` sea the ice damps (its
    cells' ice gathered from four ranks); and a pack pressed together whose touching pairs
    weld into new joints across the ranks (``weld``, and ``weld4`` with every element moving
    to the next rank). The final state, joints and the diagnostics and fields at every
    diagnostics step equal one rank's bit for bit."""
    names = ("collision", "cycle4", "ridge_freeze_split", "spectral", "weld", "weld4")
    run_cases(4, tmp_path, names)
    for name in names:
        many = np.load(tmp_path / f"{name}.npz")
        assert_same_bits(one_rank(name), many, name)
        assert bool(many["ranks_joints_agree"])
    cycle = np.load(tmp_path / "cycle4.npz")
    assert int(cycle["ranks_migrated"]) >= 27 * 10  # each element moved at 60, 120, ... 1680
    assert int(cycle["n_broken_total"]) >= 2
    for name in ("weld", "weld4"):
        assert_welds_across(one_rank(name), np.load(tmp_path / f"{name}.npz"), 4)
    assert int(np.load(tmp_path / "weld4.npz")["ranks_migrated"]) >= 3 * 15


@needs_mpi
def test_a_rank_killed_ends_the_run_with_one_line(tmp_path):
    """``kill -9`` of rank 1 mid-run: every rank ends within seconds, one line names the rank
    and the cause, the output keeps its snapshots and a restart of it runs on one rank."""
    import time

    import h5py

    from siku_core.run.cli import main
    from siku_core.testing.ranks_cases import spring_text

    (tmp_path / "s.toml").write_text(spring_text(6000).replace(
        "[run]", "[output]\nevery = 2.0\n\n[run]"), encoding="utf-8")
    pids = tmp_path / "pids"
    pids.mkdir()
    env = {**_env(), "SIKU_RANK_PIDS": str(pids)}
    p = subprocess.Popen([sys.executable, "-m", "siku_core.run.cli", "run", "s.toml", "--out",
                          "k.h5", "--no-progress", "--no-plots", "--ranks", "2"], cwd=tmp_path,
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + TIMEOUT
        rank1 = None
        while time.monotonic() < end and p.poll() is None:
            ranks = {f.read_text(): int(f.name) for f in pids.iterdir() if f.name.isdigit()}
            if "1" in ranks and (tmp_path / "k.h5").exists():
                rank1 = ranks["1"]
                break
            time.sleep(0.2)
        assert rank1 is not None, p.communicate()[1]
        time.sleep(2.0)  # mid-run: some snapshots written
        os.kill(rank1, 9)
        t0 = time.monotonic()
        out, err = p.communicate(timeout=60)
        assert time.monotonic() - t0 < 30
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode != 0
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert lines == ["siku: error: rank 1 ended (Killed (signal 9)); the run stopped on every "
                     "rank"], err + out
    assert "BAD TERMINATION" not in out
    with h5py.File(tmp_path / "k.h5", "r", swmr=True) as f:
        assert len(f["states/step"]) >= 1
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["run", "s.toml", "--restart", "k.h5", "--no-progress",
                     "--no-plots"]) == 0
    finally:
        os.chdir(cwd)
    with h5py.File(tmp_path / "k.h5", "r") as f:
        assert int(f["states/step"][-1]) == 6000


def test_conformance_catches_a_source_that_reads_other_elements(monkeypatch):
    """The forcing conformance check for ranks fails a source whose force on an element
    depends on the others (here: the mean velocity of all), and passes it otherwise."""
    from siku_core.testing import conformance

    case = next(c for c in conformance.forcing_cases(sources=("coriolis",)))
    conformance.check_forcing_on_ranks(case)
    cls = type(conformance.build_forcing(case)[1])

    def add(self, t, q, V, w, F, T):
        F[:, 0] += 1e3 * (1.0 + V[:, 0].mean() + len(V))
    monkeypatch.setattr(cls, "add", add)
    with pytest.raises(AssertionError, match="must act on each element by itself"):
        conformance.check_forcing_on_ranks(case)


def test_ranks_as_threads_take_turns_and_end_on_an_error_or_a_missing_call():
    """The ranks of the forcing conformance check (threads of one process): collective calls
    give every rank's values by rank, one rank runs at a time, and a rank that raises or
    ends without a collective call the others make ends the run with an error, not a hang."""
    from siku_core.testing.rank_threads import run_ranks

    running = []

    def rank(comm):
        running.append(comm.rank)
        a = comm.allgather(comm.rank * 10)
        running.append(comm.rank)
        b = comm.alltoall([(comm.rank, s) for s in range(comm.size)])
        return a, b
    got = run_ranks([rank] * 3)
    assert [g[0] for g in got] == [[0, 10, 20]] * 3
    assert [g[1] for g in got] == [[(s, r) for s in range(3)] for r in range(3)]
    assert running == [0, 1, 2, 0, 1, 2]  # in turn, handed on at each collective call

    def failing(comm):
        if comm.rank == 1:
            raise ValueError("rank 1 failed")
        return comm.allgather(1)
    with pytest.raises(ValueError, match="rank 1 failed"):
        run_ranks([failing] * 2, timeout=30.0)

    def short(comm):
        return comm.allgather(1) if comm.rank == 0 else None
    with pytest.raises(RuntimeError, match="rank 1 ended without collective call 0"):
        run_ranks([short] * 2, timeout=30.0)


@needs_mpi
@pytest.mark.slow
def test_default_scene_for_an_hour_same_file_on_two_ranks(tmp_path):
    """The shipped default scene (mesh, drags, Coriolis, distributed_spring) for 1 h of model
    time: ``--ranks 2`` writes the one-rank file byte for byte."""
    base = [sys.executable, "-m", "siku_core.run.cli", "run", "--set", "time.duration=1h",
            "--no-progress", "--no-plots", "--out"]
    for out, extra in (("one.h5", []), ("two.h5", ["--ranks", "2"])):
        p = subprocess.run([*base, out, *extra], cwd=tmp_path, env=_env(),
                           capture_output=True, text=True, timeout=1800)
        assert p.returncode == 0, p.stderr
    assert (tmp_path / "one.h5").read_bytes() == (tmp_path / "two.h5").read_bytes()


@needs_mpi
@pytest.mark.slow
def test_restart_on_three_ranks_writes_the_one_rank_file(tmp_path):
    """A file written on two ranks, continued on three, equals it continued on one."""
    from siku_core.testing.ranks_cases import spring_text

    (tmp_path / "scene.toml").write_text(spring_text(1500).replace(
        "[run]", '[output]\nevery = 2.0\n\n[run]'), encoding="utf-8")
    base = [sys.executable, "-m", "siku_core.run.cli", "run", "scene.toml", "--no-progress",
            "--no-plots"]
    for extra in (["--out", "two.h5", "--ranks", "2"],
                  ["--restart", "two.h5", "--extend", "30s", "--out", "on1.h5"],
                  ["--restart", "two.h5", "--extend", "30s", "--out", "on3.h5", "--ranks",
                   "3"]):
        p = subprocess.run([*base, *extra], cwd=tmp_path, env=_env(), capture_output=True,
                           text=True, timeout=TIMEOUT)
        assert p.returncode == 0, p.stderr
    assert (tmp_path / "on1.h5").read_bytes() == (tmp_path / "on3.h5").read_bytes()
