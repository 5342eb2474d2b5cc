"""Files siku did not write are never replaced, truncated or written to
(docs/explanation/outputs.md, "Which files siku may write").

A path that names an existing file siku did not write (told by the marks siku writes inside its
files, never by the name) is refused in one line, whatever ``--overwrite`` says; ``--overwrite``
replaces only siku's own files of the same kind; nothing is written to a device, a FIFO or a
folder given as a file; siku's readers identify a file as siku's before they do anything to it.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core.run.cli import main
from siku_core.testing.scenes import scene_text

GRID = ('[output.grid]\nlon = [-150.5, -149.0]\nlat = [74.75, 75.25]\nresolution = 0.25\n'
        'leads = false\n')


def small(grid: str = "", **output) -> str:
    """Two drifting squares, 10 min, a snapshot every 2 min."""
    out = {"file": "out.h5", "every": 120, **output}
    return scene_text([(-150.0, 75.0), {"center": (-149.6, 75.0), "velocity": (0.1, 0.0)}],
                      forcing=[{"source": "water_drag"}], duration=600, dt=60, output=out,
                      extra=grid)


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.fixture(scope="module")
def run_h5(tmp_path_factory):
    """A finished small run (its HDF5 output)."""
    d = tmp_path_factory.mktemp("run")
    (d / "scene.toml").write_text(small(), encoding="utf-8")
    cwd = os.getcwd()
    os.chdir(d)
    try:
        assert main(["run", "scene.toml", "--no-progress", "--no-plots"]) == 0
    finally:
        os.chdir(cwd)
    return d / "out.h5"


def foreign_hdf5(path: Path, marked: bool = False) -> bytes:
    """An HDF5 file of another program (optionally left "open for writing" by a kill)."""
    with h5py.File(path, "w", libver="latest") as f:
        f["data"] = np.arange(10.0)
        f.attrs["owner"] = "somebody"
    if marked:  # what a killed writer leaves: the superblock's file-consistency flags set
        with open(path, "r+b") as fh:
            head = bytearray(fh.read(48))
            head[11] = 5
            from siku_io.output.open_mark import lookup3

            head[44:48] = lookup3(bytes(head[:44])).to_bytes(4, "little")
            fh.seek(0)
            fh.write(head)
    return path.read_bytes()


# ------------------------------------------------------------------ 1: the mesh cache
def test_1_mesh_file_naming_an_existing_file_is_refused_and_kept(here, capsys):
    text = ('[time]\nduration = "10min"\ndt = 60\n[elements.mesh]\nlon = [-150.0, -149.0]\n'
            'lat = [72.0, 72.3]\nspacing = 8e3\nland = "none"\nmesh_file = "{}"\n'
            '[[forcing]]\nsource = "water_drag"\n')
    (here / "wind.nc").write_bytes(b"CDF\x01 somebody's wind")
    for target in ("wind.nc", "scene.toml"):
        (here / "scene.toml").write_text(text.format(target), encoding="utf-8")
        before = (here / target).read_bytes()
        assert main(["run", "scene.toml", "--no-progress", "--out", "m.h5", "--overwrite"]) == 2
        msg = one_error(capsys)
        assert "mesh_file" in msg and f"{target}: exists and is not a mesh cache siku wrote" \
            in msg, msg
        assert (here / target).read_bytes() == before
    # siku's own cache is still rebuilt in place when the parameters change
    (here / "scene.toml").write_text(text.format("a.mesh.npz"), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress", "--out", "m.h5"]) == 0
    first = (here / "a.mesh.npz").read_bytes()
    (here / "scene.toml").write_text(text.format("a.mesh.npz").replace("8e3", "9e3"),
                                     encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress", "--out", "m.h5", "--overwrite"]) == 0
    assert (here / "a.mesh.npz").read_bytes() != first


# ------------------------------------------------------------------ 2: [output.grid] file
def test_2_grid_file_naming_the_scene_is_refused_with_overwrite(here, capsys):
    (here / "scene.toml").write_text(small(GRID + 'file = "scene.toml"\n'), encoding="utf-8")
    before = (here / "scene.toml").read_bytes()
    assert main(["run", "scene.toml", "--no-progress", "--no-plots", "--overwrite"]) == 2
    msg = one_error(capsys)
    assert "scene.toml: the grid file would overwrite an input of this run" in msg, msg
    assert (here / "scene.toml").read_bytes() == before
    # a user's file of that name is never replaced either, and siku's own grid file is
    (here / "scene.toml").write_text(small(GRID + 'file = "mine.nc"\n'), encoding="utf-8")
    (here / "mine.nc").write_bytes(b"mine")
    assert main(["run", "scene.toml", "--no-progress", "--no-plots", "--overwrite"]) == 2
    assert "mine.nc: exists and is not a grid file siku wrote" in one_error(capsys)
    assert (here / "mine.nc").read_bytes() == b"mine"
    (here / "mine.nc").unlink()
    assert main(["run", "scene.toml", "--no-progress", "--no-plots", "--overwrite"]) == 0
    assert main(["run", "scene.toml", "--no-progress", "--no-plots", "--overwrite"]) == 0


# ------------------------------------------------------------------ 3: siku grid --out RUN
def test_3_grid_out_naming_the_run_output_is_refused(here, run_h5, capsys):
    run = here / "run.h5"
    run.write_bytes(run_h5.read_bytes())
    before = run.read_bytes()
    assert main(["grid", "run.h5", "--out", "run.h5", "--overwrite", "--lon", "-151", "-149",
                 "--lat", "74", "76", "--resolution", "0.5", "--no-progress"]) == 2
    assert "run.h5: the grid file would overwrite an input" in one_error(capsys)
    assert run.read_bytes() == before
    # an export named as the grid's --out is siku's, but of another kind: kept
    assert main(["export", "run.h5", "--out", "e.nc"]) == 0
    capsys.readouterr()
    e = (here / "e.nc").read_bytes()
    assert main(["grid", "run.h5", "--out", "e.nc", "--overwrite", "--lon", "-151", "-149",
                 "--lat", "74", "76", "--resolution", "0.5", "--no-progress"]) == 2
    assert "e.nc: exists and is not a grid file siku wrote" in one_error(capsys)
    assert (here / "e.nc").read_bytes() == e


# ------------------------------------------------------------------ 4: devices and FIFOs
def test_4_devices_fifos_and_folders_are_never_written(here, run_h5, capsys):
    import stat

    (here / "scene.toml").write_text(small(), encoding="utf-8")
    (here / "out.h5").write_bytes(run_h5.read_bytes())
    os.mkfifo(here / "fifo")
    (here / "dir").mkdir()
    targets = ["fifo", "dir"]
    try:  # a character device of our own (never /dev/null: old code replaced the node)
        os.mknod(here / "null", stat.S_IFCHR | 0o666, os.makedev(1, 3))
        targets.append("null")
    except (PermissionError, OSError):
        pass
    for target in targets:
        # real processes: a FIFO opened for reading would block one for ever
        for args in (["run", "scene.toml", "--out", target, "--overwrite", "--no-progress"],
                     ["export", "out.h5", "--out", target, "--overwrite"],
                     ["grid", "out.h5", "--out", target, "--overwrite", "--lon", "-151",
                      "-149", "--lat", "74", "76", "--resolution", "0.5", "--no-progress"]):
            p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", *args], cwd=here,
                               capture_output=True, text=True, timeout=120)
            assert p.returncode == 2, p.stderr
            lines = [ln for ln in p.stderr.splitlines() if ln.startswith("siku: error:")]
            assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
            assert ("is not a regular file" in lines[0] or "is a folder" in lines[0]), lines[0]
    assert stat.S_ISFIFO(os.stat(here / "fifo").st_mode) and (here / "dir").is_dir()
    if "null" in targets:
        assert stat.S_ISCHR(os.stat(here / "null").st_mode)


# ------------------------------------------------------------------ 5: pictures
def test_5_pictures_never_replace_the_users_own(here, run_h5, capsys):
    run = here / "run.h5"
    run.write_bytes(run_h5.read_bytes())
    mine = here / "run_speed_first.png"
    mine.write_bytes(b"\x89PNG\r\n\x1a\n my holiday")
    assert main(["plot", "run.h5", "--field", "speed", "--no-animation"]) == 2
    assert "run_speed_first.png: exists and is not a picture siku wrote" in one_error(capsys)
    assert mine.read_bytes() == b"\x89PNG\r\n\x1a\n my holiday"
    assert not (here / "run_speed_last.png").exists()
    mine.unlink()
    assert main(["plot", "run.h5", "--field", "speed"]) == 0
    drawn = {p.name for p in here.glob("run_speed*")}
    assert drawn == {"run_speed_first.png", "run_speed_last.png", "run_speed.gif"}
    assert main(["plot", "run.h5", "--field", "speed"]) == 0  # siku's own: drawn again
    gif = here / "run_speed.gif"
    gif.write_bytes(b"GIF89a mine")
    assert main(["plot", "run.h5", "--field", "speed"]) == 2
    assert "run_speed.gif: exists and is not a picture" in one_error(capsys)
    assert gif.read_bytes() == b"GIF89a mine"


# ------------------------------------------------------------------ 6: ensemble summaries
def test_6_a_changed_sweep_keeps_the_finished_sweeps_summary(here, capsys):
    from siku_io.ensemble.runs import run

    (here / "scene.toml").write_text(small(), encoding="utf-8")
    sweep = ('title = "s"\nscene = "scene.toml"\nout_dir = "ens"\n[cluster]\n'
             'scheduler = "serial"\n[[axis]]\nkey = "run.max_speed"\nvalues = [{}]\n')
    (here / "sweep.toml").write_text(sweep.format("100.0"), encoding="utf-8")
    run(here / "sweep.toml", progress=False)
    summary = here / "ens" / "summary.nc"
    before = summary.read_bytes()
    (here / "sweep.toml").write_text(sweep.format("50.0"), encoding="utf-8")
    assert main(["ensemble", "sweep.toml", "--no-progress"]) == 2
    assert "summary.nc exists and is not a summary of this sweep" in one_error(capsys)
    assert summary.read_bytes() == before
    # the same sweep again replaces its own summary
    (here / "sweep.toml").write_text(sweep.format("100.0"), encoding="utf-8")
    run(here / "sweep.toml", progress=False)


# ------------------------------------------------------------------ 7: readers
@pytest.mark.parametrize("marked", [False, True])
def test_7_readers_never_write_to_a_foreign_hdf5_file(here, capsys, marked):
    import xarray as xr

    from siku_core import DataError

    (here / "scene.toml").write_text(small(), encoding="utf-8")
    path = here / "theirs.h5"
    before = foreign_hdf5(path, marked)
    for args in (["plot", "theirs.h5"], ["grid", "theirs.h5", "--lon", "0", "1", "--lat", "0",
                                         "1", "--resolution", "0.5"],
                 ["export", "theirs.h5"], ["run", "scene.toml", "--restart", "theirs.h5",
                                           "--no-progress"]):
        assert main(args) == 2, args
        msg = one_error(capsys)
        assert "theirs.h5" in msg and "not a siku HDF5 output file" in msg, msg
        assert path.read_bytes() == before, args
    with pytest.raises(DataError, match="not a siku HDF5 output file"):
        xr.open_dataset(path, engine="siku")
    assert path.read_bytes() == before
    assert not list(here.glob("*.nc")) and not list(here.glob("*.png"))
