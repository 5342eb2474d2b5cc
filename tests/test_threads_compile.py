"""The threads ``siku run`` chooses (siku_core.parallel.ThreadTuner), the compile line and the
compile-free clock (siku_core.run.progress), and the summary's rate without the compilation
(siku_core.run.summary)."""
from __future__ import annotations

import io
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from siku_core import parallel
from siku_core.run import progress
from siku_core.run.summary import RunSummary, format_summary
from siku_core.testing import scene_text

ROOT = Path(__file__).resolve().parents[1]


def python(code: str, env: dict, timeout: float = 120) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=False, timeout=timeout, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return r


TINY = scene_text([(-150.0, 75.0), (-149.0, 75.0)], dt=60.0, duration=600.0,
                  forcing=[{"source": "water_drag"}, {"source": "coriolis"}])


def test_siku_run_chooses_the_threads_unless_the_user_set_them(tmp_path, monkeypatch):
    """``siku run`` times one thread against all (``auto_threads``) unless ``--threads`` or
    ``NUMBA_NUM_THREADS`` says how many; OpenMP's variables are left as the user set them."""
    from siku_core.run import cli
    from siku_core.run.simulation import Simulation

    seen = []
    real = Simulation.run

    def run(self, *a, **k):
        seen.append(self.auto_threads)
        return real(self, *a, **k)

    monkeypatch.setattr(Simulation, "run", run)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(TINY, encoding="utf-8")
    argv = ["run", "s.toml", "--no-progress", "--out", "o.h5", "--no-plots", "--overwrite"]
    monkeypatch.setattr(cli, "auto_threads", lambda threads: threads is None)  # no env var
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    assert cli.main(argv) == 0
    assert cli.main(argv + ["--threads", "1"]) == 0
    assert seen == [True, False]
    assert os.environ["OMP_WAIT_POLICY"] == "ACTIVE"
    monkeypatch.undo()
    assert cli.auto_threads(None, {"PATH": "/bin"})
    assert not cli.auto_threads(None, {"NUMBA_NUM_THREADS": "2"})
    assert not cli.auto_threads(2, {"PATH": "/bin"})


def test_importing_the_engine_starts_no_thread_and_sets_no_openmp_variable():
    code = ("import os, siku_core, siku_core.run.simulation, siku_core.run.cli\n"
            "from numba.np.ufunc import parallel\n"
            "print([k for k in os.environ if k.startswith(('OMP_', 'KMP_', 'GOMP_'))], "
            "parallel._is_initialized)")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMP_", "KMP_", "GOMP_"))}
    out = python(code, {**env, "PYTHONPATH": str(ROOT)}).stdout.split()
    assert out == ["[]", "False"]


def fresh_kernel():
    """A kernel numba has not compiled in this process (a new function object each call)."""
    @numba.njit
    def sum_of_squares(x):
        s = 0.0
        for i in range(x.size):
            s += x[i] * x[i]
        return s

    return sum_of_squares


def test_clock_leaves_the_compilation_out():
    from siku_core.run.phase_log import cpu_clock

    f = fresh_kernel()
    w0, c0 = time.perf_counter(), progress.clock()
    p0, q0 = time.process_time(), cpu_clock()
    with progress.CompileClock() as k:
        assert f(np.arange(3.0)) == 5.0
    wall, clocked = time.perf_counter() - w0, progress.clock() - c0
    cpu, cpu_clocked = time.process_time() - p0, cpu_clock() - q0
    assert k.count >= 1 and k.seconds > 0.0
    assert "sum_of_squares" in " ".join(k.kernels)
    assert abs((wall - clocked) - k.seconds) < 0.01 * max(1.0, k.seconds)
    assert clocked < wall - 0.9 * k.seconds
    # the CPU clock (``siku run --profile``'s CPU per step) leaves the compilation's CPU out
    assert 0.0 < k.cpu_seconds <= cpu + 1e-6
    assert abs((cpu - cpu_clocked) - k.cpu_seconds) < 0.01 * max(1.0, k.cpu_seconds)


def test_compile_line_names_the_kernel_and_says_how_long(monkeypatch):
    monkeypatch.setattr(progress, "NOTICE_AFTER", 0.0)
    monkeypatch.setattr(progress, "REFRESH", 0.01)
    out = io.StringIO()
    f = fresh_kernel()
    with progress.CompileProgress(stream=out) as p:
        f(np.ones(2))
    text = out.getvalue()
    assert p.printed and "compiling kernels" in text
    assert "now: " in text and "sum_of_squares" in text  # the kernel compiling at the time
    assert f"kernels compiled in {p.seconds:.1f} s ({p.count} kernel" in text
    quiet, off = io.StringIO(), io.StringIO()
    with progress.CompileProgress(stream=quiet):  # nothing compiles: nothing said
        f(np.ones(2))
    with progress.CompileProgress(enabled=False, stream=off):
        fresh_kernel()(np.ones(2))
    assert quiet.getvalue() == "" and off.getvalue() == ""


def test_one_compile_line_when_two_are_asked_for(monkeypatch):
    monkeypatch.setattr(progress, "NOTICE_AFTER", 0.0)
    outer, inner = io.StringIO(), io.StringIO()
    with progress.CompileProgress(stream=outer):
        with progress.CompileProgress(stream=inner) as p:
            fresh_kernel()(np.ones(2))
        assert p.count >= 1
    assert inner.getvalue() == "" and "compiling kernels" in outer.getvalue()


def test_summary_rate_is_the_steps_over_the_time_not_compiling():
    flags = np.zeros(4, dtype=np.int8)
    base = dict(title="t", flags=flags, steps=120, n_steps=120, dt=1.0, time=120.0, wall=10.0)
    line = [ln for ln in format_summary(RunSummary(**base, compile=6.0)).splitlines()
            if "wall time" in ln][0]
    assert "compiling kernels 6.0 s" in line and f"{120 / (10.0 - 6.0):.4g} steps/s" in line
    plain = format_summary(RunSummary(**base)).splitlines()
    assert any(f"({120 / 10.0:.4g} steps/s)" in ln for ln in plain)
    resumed = format_summary(RunSummary(**base, compile=0.0, run_steps=40))
    assert f"({40 / 10.0:.4g} steps/s)" in resumed  # a restart's rate: the steps it took


@pytest.mark.slow
def test_cold_run_shows_the_compile_line_and_keeps_it_out_of_the_rate(tmp_path):
    """``siku run`` with empty numba and kernel caches: the compile line on screen, the
    compile time in the summary, the rate and ``--profile`` without it."""
    (tmp_path / "s.toml").write_text(TINY, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "NUMBA_NUM_THREADS": "1", "SIKU_KERNEL_CACHE": str(tmp_path / "kernels")}
    code = ("import sys; from siku_core.run.cli import main; sys.exit(main(['run', 's.toml', "
            "'--out', 'o.h5', '--no-plots', '--profile']))")
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=False, timeout=900, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    err = r.stderr
    assert "compiling kernels" in err and "now: siku_" in err, err
    assert "kernels compiled in " in err
    wall = [ln for ln in err.splitlines() if ln.strip().startswith("wall time")][0]
    assert "compiling kernels" in wall and "steps/s without it" in wall, wall
    assert "compiling kernels" in err.split("profile:")[1], err


# ------------------------------------------------------------------ one thread or all, timed
def simulate(step_seconds, steps: int, most: int = 2):
    """Run a :class:`ThreadTuner` on ``steps`` steps whose time is ``step_seconds(k, n)`` for
    step ``k`` on ``n`` threads; returns the total time [s] and the threads of each step."""
    now = [0.0]
    used: list[int] = []
    threads = [most]
    tuner = parallel.ThreadTuner(most, lambda: now[0], lambda n: threads.__setitem__(0, n))
    for k in range(steps):
        with tuner:
            used.append(threads[0])
            now[0] += step_seconds(k, threads[0])
    return now[0], used


def test_busy_machine_runs_on_one_thread_at_most_a_few_percent_slower():
    """Two spinning threads 38 times slower than one (5 ms against 190 ms a step, measured on
    the default scene at a load of 10 on two cores): the tuner's trials of two threads stop
    after one step and come back after PATIENCE times what they lost, so the run costs less
    than 1 + 2 / PATIENCE times its time on one thread."""
    steps = 4000
    total, used = simulate(lambda k, n: 0.005 if n == 1 else 0.19, steps)
    assert total <= steps * 0.005 * (1 + 2 / parallel.PATIENCE)
    assert used.count(1) >= steps - 5


def test_idle_machine_runs_on_all_threads_within_a_few_percent():
    """Two threads 1.7 times faster than one: after FIRST_TRIAL steps the tuner keeps two, and
    its later trials of one thread (doubling waits) cost under 2 % of the run."""
    steps = 4000
    total, used = simulate(lambda k, n: 0.005 if n == 1 else 0.003, steps)
    assert used[parallel.FIRST_TRIAL + parallel.TRIAL_STEPS:].count(2) >= 0.99 * (
        steps - parallel.FIRST_TRIAL - parallel.TRIAL_STEPS)
    assert total <= 1.02 * steps * 0.003 + (parallel.FIRST_TRIAL + parallel.TRIAL_STEPS) * 0.005


def test_a_machine_that_becomes_busy_is_noticed_within_a_few_steps():
    """Two threads fast until step 1000, then 40 times slower than one: the tuner moves to one
    thread once the median of its last 8 steps has doubled (5 slow steps; a regular trial
    compared with the steps before the change may lose once first), not after the waits
    between regular trials."""
    def cost(k, n):
        if n == 1:
            return 0.005
        return 0.003 if k < 1000 else 0.2

    total, used = simulate(cost, 2000)
    assert used[999] == 2
    assert all(n == 1 for n in used[1000 + 20:1000 + 60])  # moved within 20 steps
    assert used[1100:].count(2) <= 10


def test_results_do_not_depend_on_the_switching():
    """A run whose thread count the tuner changes gives the state of a run on one thread, bit
    for bit (the loops' chunks do not depend on the threads)."""
    import pytest

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two numba threads")
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing.contact_conformance import contact_scene_text, square_pack

    pack = square_pack(0.0, -1.0, 60, 40, 20000.0, left="static", right="steady",
                       right_velocity=[3.0, 0.0])
    text = contact_scene_text("distributed_spring", {"tensile_strain": 0.05}, packs=[pack],
                              dt=2.0, steps=40)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = Simulation(scene_from_text(text), out=False, progress=False).run()
        numba.set_num_threads(2)
        auto = Simulation(scene_from_text(text), out=False, progress=False)
        auto.auto_threads = True
        auto.run()
    finally:
        numba.set_num_threads(before)
    assert len(parallel.LAST_TUNED) == 2  # both counts ran steps
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(one.state, k), getattr(auto.state, k)), k
