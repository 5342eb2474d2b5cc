"""Every writer survives a full disk (docs/explanation/outputs.md): one ``siku: error:`` line
naming the file, exit status 2, no partial file left, the previous file whole.

The disk is filled with the kernel's file-size limit (``RLIMIT_FSIZE``, set in the child
process only, ``SIGXFSZ`` ignored): every write past it fails with ``EFBIG`` as a full disk's
fails with ``ENOSPC``.
"""
from __future__ import annotations

import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from siku_core.testing.scenes import scene_text

GRID = ('[output.grid]\nlon = [-151.0, -149.0]\nlat = [74.5, 75.5]\nresolution = 0.25\n'
        'leads = false\n')


def siku(args, cwd: Path, limit: int | None = None):
    """``siku ARGS`` in a child process whose files may not grow past ``limit`` bytes."""
    def cap():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", *args], cwd=cwd, text=True,
                       capture_output=True, preexec_fn=cap if limit else None, timeout=300)
    return p.returncode, p.stderr


def disk_full_line(rc: int, err: str, name: str) -> str:
    assert rc == 2, err
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert len(lines) == 1, err
    assert f"{name}: disk full" in lines[0], lines[0]
    return lines[0]


def no_partial(d: Path) -> None:
    left = [p.name for p in d.rglob(".*") if p.name.endswith((".partial", ".tmp"))]
    assert not left, left


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    """A folder with a finished run (``run.h5``, 100 snapshots) and its scene."""
    d = tmp_path_factory.mktemp("disk")
    text = scene_text([(-150.0, 75.0), {"center": (-149.6, 75.0), "velocity": (0.1, 0.0)}],
                      forcing=[{"source": "water_drag"}], duration=6000, dt=60,
                      output={"file": "run.h5", "every": 60})
    (d / "scene.toml").write_text(text, encoding="utf-8")
    rc, err = siku(["run", "scene.toml", "--no-progress", "--no-plots"], d)
    assert rc == 0, err
    return d


def test_8_the_netcdf_writer_ends_a_full_disk_with_one_line(done):
    """It printed the right line and then crashed (exit 139) freeing the file it could not
    close."""
    from siku_io.output.netcdf import complete_records

    text = (done / "scene.toml").read_text().replace('file = "run.h5"', 'file = "w.nc"\n'
                                                     'writer = "netcdf"')
    (done / "w.toml").write_text(text.replace("duration = 6000", "duration = 60000"),
                                 encoding="utf-8")
    rc, err = siku(["run", "w.toml", "--no-progress", "--no-plots"], done, limit=60000)
    line = disk_full_line(rc, err, "w.nc")
    assert "complete snapshots" in line
    n = complete_records(done / "w.nc")
    assert 1 <= n < 1001
    no_partial(done)


@pytest.mark.parametrize("what", ["export", "grid", "plot"])
def test_9_export_grid_and_pictures_end_a_full_disk_with_one_line(done, tmp_path, what):
    """They ended with a RuntimeError traceback and left their partial files."""
    d = tmp_path
    (d / "run.h5").write_bytes((done / "run.h5").read_bytes())
    args = {"export": ["export", "run.h5", "--out", "x.nc"],
            "grid": ["grid", "run.h5", "--out", "x.nc", "--lon", "-151", "-149", "--lat",
                     "74.5", "75.5", "--resolution", "0.25", "--no-progress"],
            "plot": ["plot", "run.h5", "--field", "speed", "--no-animation"]}[what]
    name = "run_speed_first.png" if what == "plot" else "x.nc"
    rc, err = siku(args, d, limit=2000)
    disk_full_line(rc, err, name)
    assert not (d / name).exists()
    no_partial(d)
    # a file written before stays whole when the new one does not fit
    rc, err = siku(args, d)
    assert rc == 0, err
    before = (d / name).read_bytes()
    rc, err = siku(args + ([] if what == "plot" else ["--overwrite"]), d, limit=2000)
    disk_full_line(rc, err, name)
    assert (d / name).read_bytes() == before
    no_partial(d)


def test_9_the_ensemble_summary_ends_a_full_disk_with_one_line(done, tmp_path):
    d = tmp_path
    (d / "scene.toml").write_text((done / "scene.toml").read_text(), encoding="utf-8")
    (d / "sweep.toml").write_text('scene = "scene.toml"\nout_dir = "ens"\n[cluster]\n'
                                  'scheduler = "serial"\n[[axis]]\nkey = "run.max_speed"\n'
                                  'values = [100.0]\n', encoding="utf-8")
    rc, err = siku(["ensemble", "sweep.toml", "--no-progress"], d)
    assert rc == 0, err
    summary = d / "ens" / "summary.nc"
    before = summary.read_bytes()
    # the members are complete (reused, not written): only the summary meets the full disk
    rc, err = siku(["ensemble", "sweep.toml", "--no-progress"], d, limit=2000)
    disk_full_line(rc, err, "summary.nc")
    assert summary.read_bytes() == before
    no_partial(d)


def test_the_mesh_cache_ends_a_full_disk_with_one_line(tmp_path):
    text = ('[time]\nduration = "10min"\ndt = 60\n[elements.mesh]\nlon = [-150.0, -149.0]\n'
            'lat = [72.0, 72.3]\nspacing = 8e3\nland = "none"\nmesh_file = "m.mesh.npz"\n'
            '[[forcing]]\nsource = "water_drag"\n')
    (tmp_path / "scene.toml").write_text(text, encoding="utf-8")
    rc, err = siku(["run", "scene.toml", "--no-progress", "--no-plots"], tmp_path, limit=1000)
    disk_full_line(rc, err, "m.mesh.npz")
    assert not (tmp_path / "m.mesh.npz").exists()
    no_partial(tmp_path)


def test_a_further_netcdf_writers_full_disk_advises_restart_and_the_advice_keeps_the_data(
        tmp_path):
    """A full disk stops the further NetCDF writer (two 48-gons: its outlines at every snapshot
    make its file grow fastest). Its line advises ``--restart`` of the run's first file (on
    main: "run the scene again", which replaces both files); followed once there is room,
    both files are continued whole: every snapshot of the scene once, in order."""
    import math

    import xarray as xr

    from siku_io.output.netcdf import complete_records

    def gon(lon, lat, r=0.05, n=48):
        c = math.cos(math.radians(lat))
        return [[lon + r / c * math.cos(2 * math.pi * k / n),
                 lat + 0.5 * r * math.sin(2 * math.pi * k / n)] for k in range(n)]

    d = tmp_path
    text = scene_text([gon(-150.0, 75.0), {"vertices": gon(-149.6, 75.0),
                                           "velocity": (0.1, 0.0)}],
                      forcing=[{"source": "water_drag"}], duration=6000, dt=60,
                      output={"file": "run.h5", "every": 60})
    (d / "scene.toml").write_text(text + '\n[[output.extra]]\nwriter = "netcdf"\n'
                                  'file = "w.nc"\n', encoding="utf-8")
    rc, err = siku(["run", "scene.toml", "--no-progress", "--no-plots"], d, limit=100000)
    line = disk_full_line(rc, err, "w.nc")
    assert "--restart run.h5" in line and "run the scene again" not in line, line
    assert 1 <= complete_records(d / "w.nc") < 101
    rc, err = siku(["run", "scene.toml", "--restart", "run.h5", "--no-progress",
                    "--no-plots"], d)
    assert rc == 0, err
    h5 = xr.open_dataset(d / "run.h5", engine="siku")
    nc = xr.open_dataset(d / "w.nc")
    assert list(h5["step"].values) == list(range(0, 101)), h5["step"].values
    assert list(nc["step"].values) == list(range(0, 101)), nc["step"].values
    assert (nc["lon"].notnull()).all()
    no_partial(d)
