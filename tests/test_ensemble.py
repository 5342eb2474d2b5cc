"""Ensembles on Dask (``siku ensemble``, ``siku_io.ensemble.runs.run``): members identical to
``siku run``, failures isolated, interrupted sweeps resumed, the summary dataset, bad sweep
files.

The sweep is the rheology-comparison example (a 4 × 12 pack, 48 elements) for 20 minutes:
the three contact laws times a zipped wind axis (two values of the anticyclone's ``vmax`` and
``rmax``), six members, on a local cluster of two worker processes.
"""
from __future__ import annotations

import hashlib
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core.run import cli
from siku_io.ensemble import runs as ensemble
from siku_io.ensemble.sweep import load_sweep, toml_value
from siku_io.output.results import run_progress

pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "rheology_comparison.toml"
LAWS = ["collision", "distributed_spring", "mohr_coulomb"]

SWEEP = f"""
title = "laws and winds"
scene = {toml_value(str(SCENE))}
out_dir = "runs"

[set]
"time.duration" = "{{duration}}"
"output.every" = "10min"

[[axis]]
key = "contact.law"
values = {toml_value(LAWS)}

[[axis]]
name = "wind"
[axis.zip]
"forcing.0.field.params.vmax" = [8.0, 11.0]
"forcing.0.field.params.rmax" = [4e5, 5e5]

[summary]
final = ["joints_broken", "mean_speed", "kinetic_energy", "mean_drift"]
series = ["mean_speed", "mean_drift"]
"""


def write_sweep(folder: Path, duration: str = "20min", name: str = "sweep.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / name
    p.write_text(SWEEP.format(duration=duration), encoding="utf-8")
    return p


def solo(command: str, out: Path) -> Path:
    """Run a member alone with ``siku run``, exactly as the summary's ``command`` says, only
    written to ``out``."""
    argv = shlex.split(command)
    assert argv[:2] == ["siku", "run"]
    argv[argv.index("--out") + 1] = str(out)
    assert cli.main(argv[1:] + ["--no-progress", "--no-plots"]) == 0
    return out


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def datasets(path: Path) -> dict:
    """Every dataset of an HDF5 file by path (values) and every attribute (by path and name)."""
    out = {}
    with h5py.File(path, "r") as f:
        out["/"] = {k: np.asarray(v).tolist() for k, v in f.attrs.items()}

        def visit(name, obj):
            out[f"{name}@attrs"] = {k: np.asarray(v).tolist() for k, v in obj.attrs.items()}
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
        f.visititems(visit)
    return out


def assert_same_results(a: Path, b: Path) -> None:
    da, db = datasets(a), datasets(b)
    assert da.keys() == db.keys()
    for k in da:
        if isinstance(da[k], np.ndarray):
            assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, k
            assert np.array_equal(da[k], db[k], equal_nan=da[k].dtype.kind == "f"), k
        else:
            assert da[k] == db[k], k


@pytest.fixture(scope="module")
def swept(tmp_path_factory, siku_dask_scheduler):
    folder = tmp_path_factory.mktemp("ensemble")
    path = write_sweep(folder)
    ds = ensemble.run(path, scheduler=siku_dask_scheduler, progress=False)
    return path, ds


def test_members_are_bit_identical_to_siku_run(swept, tmp_path):
    path, ds = swept
    assert (ds.status.values == "done").all(), ds.message.values
    for law in LAWS:
        for wind in (0, 1):
            m = ds.sel(law=law, wind=wind)
            out = Path(str(m.output.values))
            alone = solo(str(m.command.values), tmp_path / f"{law}_{wind}.h5")
            assert out.read_bytes() == alone.read_bytes(), (law, wind)


def test_summary_dims_coordinates_and_values(swept):
    path, ds = swept
    assert ds.sizes["law"] == 3 and ds.sizes["wind"] == 2
    assert list(ds.law.values) == LAWS
    assert list(ds["forcing.0.field.params.vmax"].values) == [8.0, 11.0]
    assert list(ds["forcing.0.field.params.rmax"].values) == [4e5, 5e5]
    assert ds.joints_broken.dims == ("law", "wind")
    assert ds.mean_speed_series.dims == ("law", "wind", "time")
    assert ds.joints_broken.attrs["units"] == "1" and ds.mean_speed.attrs["units"] == "m s-1"
    assert ds.mean_drift.attrs["units"] == "m" and ds.time.attrs["units"] == "s"
    # the values are the members' own diagnostics (read here with plain h5py)
    for law in LAWS:
        for wind in (0, 1):
            m = ds.sel(law=law, wind=wind)
            with h5py.File(str(m.output.values), "r") as f:
                d = f["diagnostics"]
                for q in ("joints_broken", "mean_speed", "kinetic_energy"):
                    assert float(m[q]) == float(d[q][-1])
                t = d["time"][:]
                series = m.mean_speed_series.sel(time=t).values
                assert np.array_equal(series, d["mean_speed"][:])
                # mean drift: mean great-circle distance [m] of the free elements since t = 0
                free = f["geometry/flags"][:] == 0
                lat = np.radians(f["states/lat"][:, free])
                lon = np.radians(f["states/lon"][:, free])
                R = float(f.attrs["radius"])
            # haversine (well conditioned for metres on a planet)
            hav = (np.sin((lat[-1] - lat[0]) / 2) ** 2
                   + np.cos(lat[0]) * np.cos(lat[-1]) * np.sin((lon[-1] - lon[0]) / 2) ** 2)
            drift = (2 * R * np.arcsin(np.sqrt(hav))).mean()
            assert float(m.mean_drift) == pytest.approx(drift, rel=1e-9)
    # the series end where the runs end (20 min)
    assert float(ds.time[-1]) == pytest.approx(1200.0)
    assert np.array_equal(ds.mean_speed_series.isel(time=-1).values, ds.mean_speed.values)
    # the physics the laws differ by: only joints that exist break; the floes of the
    # collision law drift with their own wind, bonded packs move (if at all) as blocks
    assert (ds.joints_broken.sel(law="collision") == 0).all()
    assert (ds.joints_broken.sel(law="distributed_spring") == 0).all()
    assert (ds.mean_drift.sel(law="collision") > ds.mean_drift.sel(law="distributed_spring")).all()
    assert ds.attrs["kind"] == "siku ensemble summary" and ds.attrs["n_failed"] == 0
    assert "contact.law" in ds.attrs["sweep"]


def test_summary_file_opens_in_xarray(swept):
    import xarray as xr

    path, ds = swept
    sw = load_sweep(path)
    with xr.open_dataset(sw.summary_path) as disk:
        assert disk.sizes == ds.sizes
        assert np.array_equal(disk.joints_broken.values, ds.joints_broken.values)
        assert list(disk.status.values.ravel()) == ["done"] * 6
        assert disk.mean_drift.attrs["units"] == "m"


def test_failing_member_is_isolated(tmp_path, siku_dask_scheduler):
    sweep = tmp_path / "fail.toml"
    sweep.write_text(f"""
scene = {toml_value(str(SCENE))}
[set]
"time.duration" = "10min"
[[axis]]
key = "contact.law"
values = ["mohr_coulomb", "no_such_law"]
[[axis]]
key = "run.max_speed"
values = [100.0, 1e-4]
""", encoding="utf-8")
    ds = ensemble.run(sweep, scheduler=siku_dask_scheduler, progress=False)
    st = ds.status.sel(law="mohr_coulomb")
    assert st.sel(run_max_speed=100.0) == "done"
    assert st.sel(run_max_speed=1e-4) == "failed"  # diverges (above 1e-4 m/s) in a worker
    msg = str(ds.message.sel(law="mohr_coulomb", run_max_speed=1e-4).values)
    assert "max_speed" in msg and "\n" not in msg
    for v in (100.0, 1e-4):  # an unknown law: refused before running, with the known ones
        m = str(ds.message.sel(law="no_such_law", run_max_speed=v).values)
        assert ds.status.sel(law="no_such_law", run_max_speed=v) == "failed"
        assert "no_such_law" in m and "mohr_coulomb" in m
    assert ds.attrs["n_failed"] == 3
    assert np.isfinite(ds.kinetic_energy.sel(law="mohr_coulomb", run_max_speed=100.0))
    assert np.isnan(ds.kinetic_energy.sel(law="no_such_law")).all()
    # the command line reports them and exits 1
    out = tmp_path / "cli"
    rc = cli.main(["ensemble", str(sweep), "--scheduler", siku_dask_scheduler,
                   "--out-dir", str(out), "--no-progress"])
    assert rc == 1


def test_interrupted_sweep_resumes_without_rerunning_finished_members(tmp_path,
                                                                      siku_dask_scheduler):
    sweep = write_sweep(tmp_path, duration="6h")
    sw = load_sweep(sweep)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    # (SIGINT as a terminal's Ctrl-C delivers it, even where this test runs in the background)
    proc = subprocess.Popen([sys.executable, "-m", "siku_core.run.cli", "ensemble", str(sweep),
                             "--workers", "2", "--no-progress"], cwd=tmp_path, env=env,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    finished: dict[str, tuple] = {}
    try:
        deadline = time.monotonic() + 240
        while not finished and time.monotonic() < deadline and proc.poll() is None:
            for m in sw.members:
                if m.output.exists():
                    try:
                        if run_progress(m.output)["complete"]:
                            st = m.output.stat()
                            finished[m.name] = (st.st_ino, st.st_mtime_ns, sha(m.output))
                    except Exception:  # noqa: BLE001 - still being written
                        pass
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err
    complete = {m.name for m in sw.members if m.output.exists() and run_progress(m.output)[
        "complete"]}
    assert finished and finished.keys() <= complete
    assert len(complete) < len(sw.members), "the sweep finished before the interruption"
    before = {n: (m.output.stat().st_ino, m.output.stat().st_mtime_ns, sha(m.output))
              for m in sw.members for n in [m.name] if n in complete}
    cut = [m for m in sw.members if m.output.exists() and m.name not in complete]
    ds = ensemble.run(sweep, scheduler=siku_dask_scheduler, progress=False)
    assert (ds.status.values != "failed").all(), ds.message.values
    for m in sw.members:
        status = str(ds.status.values[m.index])
        if m.name in complete:
            assert status == "reused"
            st = m.output.stat()
            assert (st.st_ino, st.st_mtime_ns, sha(m.output)) == before[m.name]
        else:
            assert status == "done"
        assert run_progress(m.output)["complete"]
    # every member holds what an uninterrupted siku run writes: those cut short continued
    # from their last snapshot (bit-for-bit restart), the others ran (or were kept) whole
    for m in sw.members:
        alone = solo(m.command(), tmp_path / "alone" / f"{m.name}.h5")
        if m in cut:
            assert_same_results(m.output, alone)
        else:
            assert sha(m.output) == sha(alone)


def test_serial_scheduler_matches(swept, tmp_path):
    """``scheduler="serial"`` (this process, no Dask) writes the same files as the cluster."""
    path, ds = swept
    sweep = write_sweep(tmp_path)
    serial = ensemble.run(sweep, scheduler="serial", progress=False)
    for a, b in zip(serial.output.values.ravel(), ds.output.values.ravel()):
        assert Path(a) != Path(b) and sha(Path(a)) == sha(Path(b))


def test_replicates_and_draws(tmp_path):
    """Replicate r sets its key to seed + r; draws are reproducible from their seed and lie in
    their distribution's support; the members are the product of the axes."""
    sweep = tmp_path / "draws.toml"
    sweep.write_text(f"""
scene = {toml_value(str(SCENE))}
[[axis]]
name = "sample"
n = 5
seed = 7
[axis.draw]
"materials.ice.youngs_modulus" = {{ distribution = "loguniform", low = 5e8, high = 5e9 }}
"elements.thickness" = {{ distribution = "uniform", low = 0.5, high = 2.0 }}
[replicates]
n = 3
seed = 10
""", encoding="utf-8")
    a, b = load_sweep(sweep), load_sweep(sweep)
    assert len(a.members) == 15 and a.shape == (5, 3)
    assert [m.overrides for m in a.members] == [m.overrides for m in b.members]
    E = [float(m.overrides["materials.ice.youngs_modulus"]) for m in a.members]
    h = [float(m.overrides["elements.thickness"]) for m in a.members]
    assert all(5e8 <= e <= 5e9 for e in E) and all(0.5 <= x <= 2.0 for x in h)
    rng = np.random.default_rng(7)  # the documented order: keys as listed, n draws each
    expect = np.exp(rng.uniform(np.log(5e8), np.log(5e9), 5))
    assert E[::3] == [float(x) for x in expect]
    assert [m.overrides["run.seed"] for m in a.members[:3]] == ["10", "11", "12"]
    assert a.members[4].name == "sample-1__replicate-1"


BAD = [
    ("mode = 1\n", "unknown key 'mode'"),
    ('[[axis]]\nkey = "contact.frction"\nvalues = [1.0]\n', "contact.frction"),
    ('[[axis]]\nkey = "contact.params.frction"\nvalues = [1.0]\n', "frction"),
    ('[[axis]]\nkey = "time.dt"\nvalues = []\n', "time.dt"),
    ('[[axis]]\nzip = { "time.dt" = [5.0, 10.0], "run.seed" = [1] }\n', "run.seed"),
    ('[[axis]]\nname = "x"\ndraw = { "time.dt" = { distribution = "uniform", low = 1.0, '
     'high = 2.0 } }\n', "draw needs n"),
    ('[[axis]]\nname = "x"\nn = 2\ndraw = { "time.dt" = { distribution = "uniform", '
     'low = 3.0, high = 2.0 } }\n', "time.dt"),
    ('[set]\n"time.dt" = 5.0\n[[axis]]\nkey = "time.dt"\nvalues = [1.0]\n', "time.dt"),
    ('[summary]\nfinal = ["broken_joints"]\n', "broken_joints"),
    ('[cluster]\nscheduler = "tcp://127.0.0.1:9"\ntimeout = 2\n', "scheduler"),
    ("[[axis]\n", "TOML syntax"),
]


@pytest.mark.parametrize("body, key", BAD)
def test_bad_sweep_files_exit_2_naming_file_and_key(tmp_path, capsys, body, key):
    path = tmp_path / "bad.toml"
    path.write_text(f"scene = {toml_value(str(SCENE))}\n" + body, encoding="utf-8")
    t0 = time.monotonic()
    rc = cli.main(["ensemble", str(path), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1 and err.startswith("siku: error: "), err
    assert str(path) in err and key in err, err
    assert "Traceback" not in err
    assert time.monotonic() - t0 < 60  # never a hang (the scheduler's timeout is 2 s)


def test_missing_scene_and_sweep(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('scene = "nowhere.toml"\n', encoding="utf-8")
    assert cli.main(["ensemble", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "'scene'" in err and "nowhere.toml" in err
    assert cli.main(["ensemble", str(tmp_path / "none.toml")]) == 2
    assert "none.toml" in capsys.readouterr().err


def test_summary_never_replaces_a_foreign_file(tmp_path, capsys):
    sweep = write_sweep(tmp_path)
    target = load_sweep(sweep).summary_path
    target.parent.mkdir(parents=True)
    target.write_bytes(b"someone's data")
    assert cli.main(["ensemble", str(sweep), "--scheduler", "serial", "--no-progress"]) == 2
    assert target.read_bytes() == b"someone's data"
    assert "summary.nc" in capsys.readouterr().err
    assert not any(m.output.exists() for m in load_sweep(sweep).members)
