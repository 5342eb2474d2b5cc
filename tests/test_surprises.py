"""What a newcomer meets at the command line, each a one-line answer that points the right
way: a restart with a new duration, a duration shorter than a step, a run after Ctrl-C, an
output given as the scene, and the pictures' refusal naming only options ``siku plot`` has."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core.run import cli
from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

ROOT = Path(__file__).resolve().parents[1]


def siku(*args, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "siku_core.run.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, env=env, timeout=300)


def one_line(r):
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    return lines[0]


@pytest.fixture
def stopped(tmp_path):
    """A 10-step scene (dt = 60 s) whose run stopped after 4 steps: its file ends at 240 s."""
    (tmp_path / "s.toml").write_text(scene_text(
        [(0.0, 80.0)], dt=60.0, duration=600.0, output={"file": "o.h5", "every": 60.0}))
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        Simulation(load_scene("s.toml"), progress=False).run(steps=4)
    finally:
        os.chdir(cwd)
    return tmp_path


def times(path):
    with h5py.File(path, "r") as f:
        return f["states/time"][:]


def test_a_restart_with_a_duration_before_the_file_end_is_refused(stopped):
    line = one_line(siku("run", "s.toml", "--restart", "o.h5", "--set", "time.duration=2min",
                         "--no-progress", cwd=stopped))
    assert "o.h5: the scene's duration 120 s ends before the file's last snapshot " \
           "(step 4, t = 240 s)" in line and "--extend" in line
    assert times(stopped / "o.h5").tolist() == [0, 60, 120, 180, 240]  # untouched


@pytest.mark.parametrize("duration, end", [("6min", 360.0), ("20min", 1200.0)])
def test_a_restart_with_a_new_duration_ends_there(stopped, duration, end):
    r = siku("run", "s.toml", "--restart", "o.h5", "--set", f"time.duration={duration}",
             "--no-progress", cwd=stopped)
    assert r.returncode == 0, r.stderr
    assert np.array_equal(times(stopped / "o.h5"), np.arange(0.0, end + 1.0, 60.0))


def test_a_duration_shorter_than_one_step_is_refused(tmp_path):
    (tmp_path / "s.toml").write_text(scene_text([(0.0, 80.0)], dt=60.0, duration=30.0))
    line = one_line(siku("run", "s.toml", "--no-progress", cwd=tmp_path))
    assert "s.toml [time]: duration 30 s is shorter than one step (dt = 60 s)" in line


def test_a_second_run_over_a_stopped_one_advises_restart(stopped):
    line = one_line(siku("run", "s.toml", "--no-progress", cwd=stopped))
    assert "o.h5: exists; choose another --out, or pass --overwrite" in line
    assert line.endswith("; it is an output file siku wrote: continue it with --restart o.h5")


def test_the_python_api_names_its_own_arguments_not_the_flags(stopped, monkeypatch):
    """The same refusals through ``Simulation``: the advice names ``out=``,
    ``overwrite=True``, ``restart=``, ``force=True`` and ``extend=``, arguments the caller
    has, never a flag of ``siku run``; and the advice works."""
    from siku_core.errors import SikuError

    monkeypatch.chdir(stopped)
    scene = load_scene("s.toml")
    with pytest.raises(SikuError) as e:
        Simulation(scene, progress=False)
    msg = str(e.value)
    assert "o.h5: exists; choose another out=, or pass overwrite=True" in msg
    assert msg.endswith("continue it with restart='o.h5'") and "--" not in msg
    other = load_scene("s.toml", {"time.dt": "30s"})
    with pytest.raises(SikuError) as e:
        Simulation(other, restart="o.h5", progress=False)
    assert "pass force=True to continue anyway" in str(e.value) and "--" not in str(e.value)
    with pytest.raises(SikuError) as e:
        Simulation(scene, extend=600.0, progress=False)
    assert "extend continues a finished run: give the file with restart" == str(e.value)
    Simulation(scene, restart="o.h5", progress=False).run()  # the advice works
    with pytest.raises(SikuError) as e:
        Simulation(scene, restart="o.h5", progress=False)
    msg = str(e.value)
    assert "to run longer, add extend=SECONDS (e.g. extend=21600)" in msg and "--" not in msg
    Simulation(scene, restart="o.h5", extend=120.0, progress=False).run()
    assert np.array_equal(times(stopped / "o.h5"), np.arange(0.0, 721.0, 60.0))


def test_ctrl_c_says_how_to_continue_and_the_advice_works(stopped, monkeypatch, capsys):
    run = Simulation.run

    def interrupted(self, steps=None):
        run(self, steps=2)  # two steps written, then Ctrl-C
        raise KeyboardInterrupt

    (stopped / "o.h5").unlink()
    monkeypatch.chdir(stopped)
    monkeypatch.setattr(Simulation, "run", interrupted)
    assert cli.main(["run", "s.toml", "--no-progress"]) == 130
    err = capsys.readouterr().err
    assert "continue it with `siku run s.toml --restart o.h5`" in err
    monkeypatch.setattr(Simulation, "run", run)
    assert cli.main(["run", "s.toml", "--restart", "o.h5", "--no-progress"]) == 0
    assert np.array_equal(times(stopped / "o.h5"), np.arange(0.0, 601.0, 60.0))


def test_an_output_given_as_the_scene_is_refused_in_one_line(stopped):
    line = one_line(siku("run", "o.h5", "--no-progress", cwd=stopped))
    assert "o.h5: is an HDF5 file" in line and "siku info o.h5" in line \
        and "--restart o.h5" in line


def test_the_pictures_refusal_names_no_option_siku_plot_lacks(tmp_path):
    from siku_core.errors import DataError
    from siku_io.plot.mapdeco import picture_targets

    (tmp_path / "map.png").write_bytes(b"a user's picture")
    with pytest.raises(DataError) as ei:
        picture_targets(tmp_path, ["map.png"])
    assert "--overwrite" not in str(ei.value) and "--out-dir" in str(ei.value)
