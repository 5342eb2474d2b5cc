"""The recovery siku advises works as it says (docs/explanation/outputs.md, "Restarts that
cannot go wrong"): after a full disk, ``siku run SCENE --restart FILE`` continues FILE itself;
an ``--extend`` cut short is finished by a plain restart, and the same ``--extend`` again ends
where it would have; a NetCDF output is refused as a restart file in one line.

Faults are real child processes whose file size is capped (``RLIMIT_FSIZE``).
"""
from __future__ import annotations

import resource
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core.testing.scenes import scene_text

N = 300  # steps of the base run
DT = 60.0


def siku(args, cwd: Path, limit: int | None = None):
    def cap():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", *args, "--no-progress",
                        "--no-plots"], cwd=cwd, text=True, capture_output=True,
                       preexec_fn=cap if limit else None, timeout=300)
    assert "Traceback" not in p.stderr, p.stderr
    return p.returncode, p.stderr


def last(path: Path) -> tuple[int, np.ndarray, int]:
    with h5py.File(path, "r") as f:
        return int(f["states/step"][-1]), f["states/q"][-1], int(f.attrs["n_steps"])


@pytest.fixture(scope="module")
def ref(tmp_path_factory):
    """The base run (N steps, no [output] file: the scene's default siku_out.h5), and the
    same run extended by N/2 steps without a fault."""
    d = tmp_path_factory.mktemp("ref")
    text = scene_text([(-150.0, 75.0), {"center": (-149.6, 75.0), "velocity": (0.1, 0.0)}],
                      forcing=[{"source": "water_drag"},
                               {"source": "air_drag", "field": {"type": "uniform",
                                                                "params": {"u": 10.0}}}],
                      duration=N * DT, dt=DT, output={"every": DT})
    (d / "scene.toml").write_text(text, encoding="utf-8")
    rc, err = siku(["scene.toml", "--out", "base.h5"], d)
    assert rc == 0, err
    (d / "ext.h5").write_bytes((d / "base.h5").read_bytes())
    rc, err = siku(["scene.toml", "--restart", "ext.h5", "--extend", f"{N // 2 * DT:g}s"], d)
    assert rc == 0, err
    return d


def test_10_the_advised_restart_continues_the_file_it_names(ref, tmp_path):
    d = tmp_path
    (d / "scene.toml").write_text((ref / "scene.toml").read_text(), encoding="utf-8")
    size = (ref / "base.h5").stat().st_size
    rc, err = siku(["scene.toml", "--out", "run.h5"], d, limit=int(0.85 * size))
    assert rc == 2 and "run.h5: disk full" in err and "--restart run.h5" in err, err
    rc, err = siku(["scene.toml", "--restart", "run.h5"], d)  # as the message advises
    assert rc == 0, err
    assert "output: run.h5" in err
    assert not (d / "siku_out.h5").exists()
    step, q, _ = last(d / "run.h5")
    assert step == N and np.array_equal(q, last(ref / "base.h5")[1])
    rc, err = siku(["scene.toml", "--restart", "run.h5"], d)  # again: it says it is done
    assert rc == 2 and f"run.h5: the run is already complete (step {N} of {N}" in err, err


def test_11_an_extend_cut_short_is_finished_by_a_plain_restart_or_the_same_extend(ref,
                                                                                   tmp_path):
    d = tmp_path
    (d / "scene.toml").write_text((ref / "scene.toml").read_text(), encoding="utf-8")
    s0, s1 = (ref / "base.h5").stat().st_size, (ref / "ext.h5").stat().st_size
    end, q_end, _ = last(ref / "ext.h5")
    assert end == N + N // 2
    for how in (["--restart", "run.h5"], ["--restart", "run.h5", "--extend", f"{N // 2 * DT:g}s"]):
        (d / "run.h5").write_bytes((ref / "base.h5").read_bytes())
        rc, err = siku(["scene.toml", "--restart", "run.h5", "--extend", f"{N // 2 * DT:g}s"],
                       d, limit=(s0 + s1) // 2)
        assert rc == 2 and "run.h5: disk full" in err, err
        step, _, n_steps = last(d / "run.h5")
        assert N < step < end and n_steps == end
        rc, err = siku(["scene.toml", *how], d)
        assert rc == 0, err
        step, q, n_steps = last(d / "run.h5")
        assert (step, n_steps) == (end, end), how
        assert np.array_equal(q, q_end), how
        rc, err = siku(["scene.toml", "--restart", "run.h5"], d)
        assert rc == 2 and f"already complete (step {end} of {end}" in err, err


def test_12_a_netcdf_output_is_refused_as_a_restart_file_in_one_line(ref, tmp_path):
    d = tmp_path
    text = (ref / "scene.toml").read_text().replace("[output]", '[output]\nwriter = "netcdf"')
    (d / "scene.toml").write_text(text, encoding="utf-8")
    rc, err = siku(["scene.toml", "--out", "run.nc"], d)
    assert rc == 0, err
    before = (d / "run.nc").read_bytes()
    rc, err = siku(["scene.toml", "--restart", "run.nc"], d)
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert rc == 2 and len(lines) == 1, err
    assert "run.nc: outputs of the NetCDF writer cannot be restarted" in lines[0], lines[0]
    assert (d / "run.nc").read_bytes() == before
