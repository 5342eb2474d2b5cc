"""Nothing lost under faults (docs/explanation/outputs.md).

Runs are real ``siku run`` processes on a small bonded pack whose joints break during the run,
with a snapshot every few steps. Faults: ``kill -9`` at random moments, a full disk (the
kernel's file-size limit, ``RLIMIT_FSIZE``, makes every write past it fail with ``EFBIG`` just
as a full disk fails with ``ENOSPC``), two runs on one path, an output onto an input. After each
fault the file must open with a plain ``h5py.File``, every row must equal the same row of an
uninterrupted run, and a restart from it must finish bit for bit equal to that run.
"""
from __future__ import annotations

import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core.run.cli import default_scene_path, main
from siku_core.testing.contact_conformance import contact_scene_text, square_pack
from siku_io.output.results import open_results

STEPS = 3000
EVERY = 20  # steps per snapshot
DT = 0.1


def scene_text(steps: int = STEPS) -> str:
    pack = square_pack(30.0, 72.0, 5, 2, 2000.0, jitter=0.2, seed=7, left="static",
                       right="steady", right_velocity=[0.004, 0.0012])
    return contact_scene_text(
        "distributed_spring", {"tensile_strain": 2e-4, "damage_onset": 0.3}, packs=[pack],
        dt=DT, steps=steps, output={"file": "out.h5", "every": EVERY * DT,
                                    "diagnostics_every": 7 * DT})


def siku(args, cwd, limit: int | None = None, wait: bool = True, **kw):
    def cap():  # the file-size limit of the child only
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    cmd = [sys.executable, "-m", "siku_core.run.cli", "run", *args, "--no-progress", "--no-plots"]
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=cap if limit else None, **kw)
    if not wait:
        return p
    out, err = p.communicate(timeout=600)
    return p.returncode, err


def error_line(err: str) -> str:
    """The run's error message: exactly one ``siku: error:`` line and no traceback."""
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert len(lines) == 1, err
    return lines[0]


def start_and_wait_for_file(d: Path, *args: str):
    """Start ``siku run scene.toml`` in ``d``; return the process once its output file is in
    place (the run holds its first snapshot) and the time [s] that took."""
    p = siku(["scene.toml", *args], d, wait=False)
    t0 = time.monotonic()
    while not (d / "out.h5").exists() and time.monotonic() - t0 < 300:
        assert p.poll() is None, p.communicate()[1]
        time.sleep(0.002)
    return p


RUN_TIME = {}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run (also warms the compiled-kernel caches for the children), and how
    long it writes its file (from the first snapshot to the end: where kills should land)."""
    d = tmp_path_factory.mktemp("reference")
    (d / "scene.toml").write_text(scene_text(), encoding="utf-8")
    rc, err = siku(["scene.toml"], d)  # compiles and caches
    assert rc == 0, err
    (d / "out.h5").unlink()
    p = start_and_wait_for_file(d)
    t0 = time.monotonic()
    _, err = p.communicate(timeout=600)
    RUN_TIME["s"] = time.monotonic() - t0
    assert p.returncode == 0, err
    with h5py.File(d / "out.h5", "r") as f:
        assert 0 < f["diagnostics/joints_broken"][-1] < f["diagnostics/joints_intact"][0]
        # joints break mid-run, so kills land before and after breaks
        assert f["breaks/time"].shape[0] >= 2 and f["breaks/time"][0] > 0.3 * STEPS * DT
    return d / "out.h5"


def leaves(group, prefix=""):
    for k, v in group.items():
        if isinstance(v, h5py.Group):
            yield from leaves(v, f"{prefix}{k}/")
        else:
            yield prefix + k, v


def same(a, b) -> bool:
    """Equal element by element (NaN where the other has NaN: unbroken joints' break time)."""
    a, b = np.asarray(a), np.asarray(b)
    return np.array_equal(a, b, equal_nan=a.dtype.kind == "f" and b.dtype.kind == "f")


def assert_rows_of(path: Path, ref: Path, complete: bool = False) -> int:
    """Every counted row of ``path`` (``/states/step``, ``/diagnostics/step`` and
    ``/breaks/time`` count them) equals the same row of ``ref``; other datasets may hold the
    rows of the commit a fault cut short (one snapshot row, the diagnostics rows kept since
    the snapshot before), which the count leaves out: their data may not have reached the
    disk. Returns the number of snapshots."""
    with h5py.File(path, "r") as f, h5py.File(ref, "r") as g:
        counts = {}
        for group, marker in (("states", "step"), ("diagnostics", "step"), ("breaks", "time")):
            n = f[group][marker].shape[0]
            counts[group] = n
            if complete:
                assert n == g[group][marker].shape[0], (group, n)
            for name, ds in leaves(f[group]):
                extra = 1 if group == "states" else EVERY
                assert n <= ds.shape[0] <= n + extra, (group, name, n, ds.shape[0])
                assert same(ds[:n], g[group][name][:n]), (group, name)
        for name in ("geometry/verts", "scene", "run_record"):
            assert same(f[name][()], g[name][()])
        return counts["states"]


@pytest.mark.parametrize("kills", [3, pytest.param(20, marks=pytest.mark.slow)])
def test_kill_at_random_moments_leaves_a_file_that_opens_and_restarts_bit_for_bit(
        tmp_path, reference, kills):
    rng = np.random.default_rng(2026 + kills)
    total = STEPS // EVERY + 1
    cut_short = 0
    for k in range(kills):
        d = tmp_path / f"kill{k}"
        d.mkdir()
        (d / "scene.toml").write_text(scene_text(), encoding="utf-8")
        p = start_and_wait_for_file(d)
        time.sleep(rng.uniform(0.0, 0.6 * RUN_TIME["s"]))
        killed = p.poll() is None
        p.send_signal(signal.SIGKILL)
        p.communicate()
        out = d / "out.h5"
        try:
            h5py.File(out, "r").close()
            marked = False
        except OSError as exc:  # what a kill leaves: HDF5's "open for writing" mark
            assert "already open for write" in str(exc)
            marked = True
        with open_results(out) as f:  # siku's readers clear it (as h5clear -s does)
            assert f["states/q"].shape[1] == 10
        n = assert_rows_of(out, reference)  # now a plain h5py.File opens it
        assert marked or n == total, "only a run that closed its file leaves no mark"
        assert killed or n == total
        assert 1 <= n <= total
        cut_short += n < total
        rc, err = siku(["scene.toml", "--restart", "out.h5"], d)
        if n == total:  # the kill came after the last snapshot: nothing to continue
            assert rc == 2 and "already complete" in err, err
        else:
            assert rc == 0, err
        assert_rows_of(out, reference, complete=True)
        assert not list(d.glob(".*.partial"))
    assert cut_short >= kills // 2, "the kills should land during the runs"


def test_full_disk_ends_with_one_line_naming_the_last_snapshot_and_restarts(tmp_path,
                                                                            reference):
    size = reference.stat().st_size
    for share in (0.4, 0.7, 0.95):
        d = tmp_path / f"full{share}"
        d.mkdir()
        (d / "scene.toml").write_text(scene_text(), encoding="utf-8")
        rc, err = siku(["scene.toml"], d, limit=int(share * size))
        assert rc == 2, err
        msg = error_line(err)
        assert "out.h5: disk full while writing the" in msg, msg
        assert "the file holds complete snapshots to step" in msg and "--restart out.h5" in msg
        n = assert_rows_of(d / "out.h5", reference)  # opens without any repair
        with h5py.File(d / "out.h5", "r") as f:
            last = int(f["states/step"][n - 1])
        assert f"to step {last} " in msg
        rc, err = siku(["scene.toml", "--restart", "out.h5"], d)
        assert rc == 0, err
        assert_rows_of(d / "out.h5", reference, complete=True)
        assert not list(d.glob(".*.partial"))


def test_full_disk_before_the_first_snapshot_leaves_nothing_and_keeps_an_old_file(tmp_path,
                                                                                  reference):
    (tmp_path / "scene.toml").write_text(scene_text(), encoding="utf-8")
    rc, err = siku(["scene.toml"], tmp_path, limit=4096)
    assert rc == 2 and "out.h5: disk full" in error_line(err) and "nothing written" in err
    assert not (tmp_path / "out.h5").exists() and not list(tmp_path.glob(".*.partial"))
    # --overwrite on a nearly full disk: the good file stays whole
    good = tmp_path / "out.h5"
    good.write_bytes(reference.read_bytes())
    before = good.read_bytes()
    rc, err = siku(["scene.toml", "--overwrite"], tmp_path, limit=4096)
    assert rc == 2 and "existing file is untouched" in error_line(err)
    assert good.read_bytes() == before


def test_two_runs_on_one_path(tmp_path, reference):
    """A second run on the path of a running one is refused, with or without --overwrite, and
    the first finishes with a whole file, row for row the reference's. The first run is
    stopped (``SIGSTOP``) as soon as its file is in place and continued (``SIGCONT``) after
    both refusals: it is still running, holding its file, whatever the load of the machine."""
    (tmp_path / "scene.toml").write_text(scene_text(), encoding="utf-8")
    first = start_and_wait_for_file(tmp_path)
    first.send_signal(signal.SIGSTOP)
    try:
        assert first.poll() is None, "the first run should still be running"
        rc, err = siku(["scene.toml"], tmp_path)
        assert rc == 2 and "out.h5: exists; choose another --out, or pass --overwrite" in \
            error_line(err)
        rc, err = siku(["scene.toml", "--overwrite"], tmp_path)
        assert rc == 2 and "is being written by another run" in error_line(err)
        assert first.poll() is None
    finally:
        first.send_signal(signal.SIGCONT)
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    assert assert_rows_of(tmp_path / "out.h5", reference, complete=True) == STEPS // EVERY + 1
    assert not list(tmp_path.glob(".*.partial"))


def test_output_onto_an_input_is_refused_and_the_input_kept(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(steps=10), encoding="utf-8")
    before = scene.read_bytes()
    assert main(["run", str(scene), "--out", str(scene), "--no-progress"]) == 2
    # the scene is named relative to the working directory, as every message names files
    assert "the output file would overwrite an input of this run (scene file: scene.toml)" in \
        capsys.readouterr().err
    assert scene.read_bytes() == before
    wind = default_scene_path().parent / "uwnd.anticyclone.nc"
    wind_before = wind.read_bytes()
    assert main(["run", "--out", str(wind), "--no-progress", "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert "would overwrite an input of this run ([forcing[0].field.params.u_file]" in err
    assert wind.read_bytes() == wind_before


def test_an_existing_file_is_never_replaced_unless_told(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(scene_text(steps=40), encoding="utf-8")
    (tmp_path / "out.h5").write_bytes(b"somebody's results")
    assert main(["run", "scene.toml", "--no-progress"]) == 2
    assert "out.h5: exists" in capsys.readouterr().err
    assert (tmp_path / "out.h5").read_bytes() == b"somebody's results"
    # --overwrite replaces only a file siku wrote (told by the marks inside it, not its name)
    assert main(["run", "scene.toml", "--no-progress", "--overwrite"]) == 2
    assert "out.h5: exists and is not an output file siku wrote" in capsys.readouterr().err
    assert (tmp_path / "out.h5").read_bytes() == b"somebody's results"
    (tmp_path / "out.h5").unlink()
    (tmp_path / "scene.toml").write_text(scene_text(steps=20), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress"]) == 0
    (tmp_path / "scene.toml").write_text(scene_text(steps=40), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress", "--overwrite"]) == 0
    with h5py.File(tmp_path / "out.h5", "r") as f:
        assert f["states/step"][-1] == 40
    assert not list(tmp_path.glob(".*.partial"))


def test_a_run_that_fails_before_its_first_new_snapshot_leaves_the_old_file(tmp_path, monkeypatch,
                                                                           capsys):
    """A restart that stops (here: a non-finite velocity injected into the restart file
    refuses it before step 1) never touches the file it would continue."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(scene_text(steps=40), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress"]) == 0
    with h5py.File("out.h5", "r+") as f:
        f["states/V"][-1, 3, 0] = np.nan
    before = (tmp_path / "out.h5").read_bytes()
    assert main(["run", "scene.toml", "--no-progress", "--restart", "out.h5", "--extend",
                 "2s"]) == 2
    assert "element 3 starts with a non-finite velocity" in capsys.readouterr().err
    assert (tmp_path / "out.h5").read_bytes() == before



def test_a_killed_netcdf_run_leaves_a_file_of_real_rows_and_missing_values(tmp_path):
    """The NetCDF writer (``siku_io.output.netcdf``): after ``kill -9`` at random moments the file
    opens in xarray; every record with a ``step`` equals the uninterrupted run's; a record
    without one (the write the kill cut short) holds its time and, per variable, the real row
    or missing values: never other numbers."""
    import xarray as xr

    from siku_io.output.netcdf import complete_records

    text = scene_text().replace('file = "out.h5"', 'file = "out.nc"\nwriter = "netcdf"')
    ref_dir = tmp_path / "ref"
    ref_dir.mkdir()
    (ref_dir / "scene.toml").write_text(text, encoding="utf-8")
    rc, err = siku(["scene.toml"], ref_dir)
    assert rc == 0, err
    ref = xr.open_dataset(ref_dir / "out.nc", decode_times=False)
    rng = np.random.default_rng(11)
    for k in range(3):
        d = tmp_path / f"kill{k}"
        d.mkdir()
        (d / "scene.toml").write_text(text, encoding="utf-8")
        p = siku(["scene.toml"], d, wait=False)
        t0 = time.monotonic()
        while not (d / "out.nc").exists() and time.monotonic() - t0 < 300:
            assert p.poll() is None, p.communicate()[1]
            time.sleep(0.002)
        time.sleep(rng.uniform(0.0, 1.0))
        p.send_signal(signal.SIGKILL)
        p.communicate()
        got = xr.open_dataset(d / "out.nc", decode_times=False)
        n = complete_records(d / "out.nc")
        assert 1 <= n <= got.sizes["time"] <= n + 1
        for name in ("lon", "lat", "u", "v", "damage", "time"):
            assert np.array_equal(got[name].values[:n], ref[name].values[:n]), name
        if got.sizes["time"] > n:  # the record the kill cut short: time, and no numbers
            assert got["time"].values[n] == ref["time"].values[n]
            for name in ("lon", "u", "damage"):
                row = got[name].values[n]
                assert np.all(np.isnan(row) | (row == ref[name].values[n])), name
