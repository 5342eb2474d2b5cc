"""How idle threads wait (siku_core.thread_env), the compile line and the compile-free clock
(siku_core.progress), and the summary's rate without the compilation (siku_core.summary)."""
from __future__ import annotations

import io
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np

from siku_core import progress
from siku_core.summary import RunSummary, format_summary
from siku_core.testing import scene_text
from siku_core.thread_env import QUIET, USER_CHOICES, set_quiet_defaults

ROOT = Path(__file__).resolve().parents[1]


def python(code: str, env: dict, timeout: float = 120) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=False, timeout=timeout, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return r


def bare_env(**extra: str) -> dict:
    """This process's environment without the thread-waiting variables, plus ``extra``."""
    env = {k: v for k, v in os.environ.items() if k not in USER_CHOICES}
    return {**env, "PYTHONPATH": str(ROOT), **extra}


def test_idle_threads_sleep_unless_the_user_chose_otherwise():
    env: dict = {}
    assert set_quiet_defaults(env) == QUIET and env == QUIET
    for k in USER_CHOICES:
        mine = {k: "ACTIVE" if k == "OMP_WAIT_POLICY" else "200000"}
        assert set_quiet_defaults(mine) == {} and len(mine) == 1, k  # nothing added or changed


def test_import_sets_the_variables_before_any_thread_starts_and_keeps_the_users():
    code = ("import os, siku_core, siku_core.simulation, siku_core.cli\n"
            "from numba.np.ufunc import parallel\n"
            "print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('KMP_BLOCKTIME'), "
            "parallel._is_initialized)")
    out = python(code, bare_env()).stdout.split()
    assert out == ["PASSIVE", "0", "False"]  # no numba thread yet: the library reads them later
    out = python(code, bare_env(OMP_WAIT_POLICY="ACTIVE")).stdout.split()
    assert out == ["ACTIVE", "None", "False"]
    out = python(code, bare_env(GOMP_SPINCOUNT="300000")).stdout.split()
    assert out == ["None", "None", "False"]


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
    f = fresh_kernel()
    w0, c0 = time.perf_counter(), progress.clock()
    with progress.CompileClock() as k:
        assert f(np.arange(3.0)) == 5.0
    wall, clocked = time.perf_counter() - w0, progress.clock() - c0
    assert k.count >= 1 and k.seconds > 0.0
    assert "sum_of_squares" in " ".join(k.kernels)
    assert abs((wall - clocked) - k.seconds) < 0.01 * max(1.0, k.seconds)
    assert clocked < wall - 0.9 * k.seconds


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


def test_cold_run_shows_the_compile_line_and_keeps_it_out_of_the_rate(tmp_path):
    """``siku run`` with empty numba and kernel caches: the compile line on screen, the
    compile time in the summary, the rate and ``--profile`` without it."""
    (tmp_path / "s.toml").write_text(
        scene_text([(-150.0, 75.0), (-149.0, 75.0)], dt=60.0, duration=600.0,
                   forcing=[{"source": "water_drag"}, {"source": "coriolis"}]), encoding="utf-8")
    env = bare_env(NUMBA_CACHE_DIR=str(tmp_path / "numba"), NUMBA_NUM_THREADS="1",
                   SIKU_KERNEL_CACHE=str(tmp_path / "kernels"))
    code = ("import sys; from siku_core.cli import main; sys.exit(main(['run', 's.toml', "
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
