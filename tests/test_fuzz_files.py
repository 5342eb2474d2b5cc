"""Property-based fuzzing of sweep files and of the readers of output files (hypothesis), as
``tests/test_fuzz_scenes.py`` fuzzes scenes: every command ends with its exit status (0, 1 for
an ensemble with failed members, 2 with exactly one ``siku: error:`` line naming a file),
never a traceback, never a hang; a reader never changes the file it reads.

* Sweeps: a valid small sweep (values, zip and draw axes, replicates, ``[set]``, ``[summary]``,
  members run one after another in this process) mutated like the scenes.
* Readers: damaged copies of siku's files (an HDF5 output, a NetCDF writer's output, an export,
  a gridded file) made by mutation: bytes flipped in the metadata or anywhere, files cut short
  or grown, blocks zeroed, datasets, groups and attributes deleted or replaced by values of
  another type or shape, states made NaN; each read by ``siku plot``, ``siku grid``, ``siku
  export``, ``siku run --restart`` and ``xr.open_dataset(..., engine="siku")``.

Fast mode: ``SWEEPS`` and ``READERS`` cases; ``pytest -m slow`` runs ``SWEEPS_LONG`` and
``READERS_LONG`` (with the 500 scenes of test_fuzz_scenes.py, over 1 000 cases) and prints the
counts.
"""
from __future__ import annotations

import copy
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from test_fuzz_scenes import (  # noqa: E402
    ADVERSARIAL,
    BASES,
    NUMBERS,
    STRINGS,
    Hang,
    at,
    paths,
    run_main,
)

from siku_core.testing.scenes import toml_value  # noqa: E402

SWEEPS, SWEEPS_LONG = 6, 200
READERS, READERS_LONG = 8, 400

SCENE = "\n".join(f"{k} = {toml_value(v)}" for k, v in BASES[0].items() if k != "output") + \
    '\noutput = { every = 300 }\n'

SWEEP: dict[str, Any] = {
    "title": "fuzz", "scene": "scene.toml", "out_dir": "ens",
    "set": {"time.duration": "10min"},
    "cluster": {"scheduler": "serial", "timeout": 5},
    "axis": [{"key": "run.max_speed", "values": [50.0, 100.0]},
             {"zip": {"forcing.0.params.C": [0.004, 0.006]}, "name": "drag"},
             {"n": 2, "seed": 1, "draw": {"planet.rotation_rate": {
                 "distribution": "uniform", "low": 7e-5, "high": 8e-5}}}],
    "replicates": {"n": 1, "key": "run.seed", "seed": 3},
    "summary": {"file": "summary.nc", "final": ["kinetic_energy"]},
}


def mutate(draw, obj: Any) -> Any:
    """A copy of ``obj`` with one to three values replaced, deleted or added (as the scenes of
    test_fuzz_scenes.py are mutated)."""
    obj = copy.deepcopy(obj)
    for _ in range(draw(st.sampled_from([1, 1, 2, 3]))):
        where = draw(st.sampled_from(paths(obj)))
        parent, key = at(obj, where[:-1]), where[-1]
        old = parent[key]
        op = draw(st.sampled_from(["same"] * 3 + ["any", "delete", "unknown"]))
        if op == "same":
            pool = (NUMBERS if isinstance(old, (int, float)) and not isinstance(old, bool)
                    else STRINGS if isinstance(old, str) else ADVERSARIAL)
            parent[key] = copy.deepcopy(draw(st.sampled_from(pool)))
        elif op == "any":
            parent[key] = copy.deepcopy(draw(st.sampled_from(ADVERSARIAL)))
        elif op == "delete" and isinstance(parent, dict):
            del parent[key]
        elif isinstance(parent, dict):
            parent[draw(st.sampled_from(["bogus", "key", "values", "n", "file"]))] = \
                copy.deepcopy(draw(st.sampled_from(ADVERSARIAL)))
    return obj


def toml_of(obj: dict) -> str:
    """Top-level tables as TOML (lists of tables as inline arrays)."""
    return "\n".join(f"{k} = {toml_value(v)}" for k, v in obj.items()) + "\n"


def one_line(rc: int, err: str, allowed=(0, 2)) -> None:
    assert "Traceback" not in err, err
    assert rc in allowed, (rc, err)
    if rc == 2:
        lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
        assert len(lines) == 1, err
        assert any(s in lines[0] for s in (".toml", ".h5", ".nc", ".npz", ".png", ".gif",
                                           "--", "ens")), lines[0]


def run_checked(args, files, what: str, after=None) -> tuple[int, str]:
    try:
        return run_main(args, files, after)
    except Hang as exc:
        pytest.fail(f"hang ({exc}) on {what}")
    except Exception as exc:  # noqa: BLE001 - a traceback is the failure looked for
        pytest.fail(f"traceback ({type(exc).__name__}: {exc}) on {what}")


# ---------------------------------------------------------------------------- sweeps
@st.composite
def sweeps(draw) -> str:
    text = toml_of(mutate(draw, SWEEP))
    if draw(st.integers(0, 19)) == 0:
        text = text[:draw(st.integers(0, len(text)))]
    return text


COUNT = {"sweeps": 0, "readers": 0, "reads": 0}


def check_sweep(text: str) -> None:
    rc, err = run_checked(["ensemble", "sweep.toml", "--no-progress"],
                          {"sweep.toml": text, "scene.toml": SCENE}, f"the sweep:\n{text}")
    one_line(rc, err, allowed=(0, 1, 2))
    COUNT["sweeps"] += 1


@settings(max_examples=SWEEPS, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(sweeps())
def test_fuzzed_sweeps_end_with_their_exit_status_and_one_line(text):
    check_sweep(text)


@pytest.mark.slow
@settings(max_examples=SWEEPS_LONG, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(sweeps())
def test_fuzzed_sweeps_long(text):
    check_sweep(text)


# ---------------------------------------------------------------------------- readers
_SOURCES: dict[str, bytes] = {}
GRID_ARGS = ["--lon", "-150.5", "-149", "--lat", "74.75", "75.25", "--resolution", "0.25",
             "--no-progress"]


def sources() -> dict[str, bytes]:
    """siku's files to damage (made once): an HDF5 output, a NetCDF writer's output, its export
    and its gridded file."""
    if not _SOURCES:
        with tempfile.TemporaryDirectory() as d:
            cwd = os.getcwd()
            os.chdir(d)
            try:
                from siku_core.run.cli import main

                Path("scene.toml").write_text(SCENE, encoding="utf-8")
                Path("w.toml").write_text(SCENE.replace("output = {", 'output = { writer = '
                                                        '"netcdf", '), encoding="utf-8")
                for args in (["run", "scene.toml", "--out", "out.h5", "--no-progress"],
                             ["run", "w.toml", "--out", "w.nc", "--no-progress"],
                             ["export", "out.h5", "--out", "e.nc"],
                             ["grid", "out.h5", "--out", "g.nc", *GRID_ARGS]):
                    assert main(args) == 0, args
                for name in ("out.h5", "w.nc", "e.nc", "g.nc"):
                    _SOURCES[name] = Path(name).read_bytes()
            finally:
                os.chdir(cwd)
    return _SOURCES


def _structural(path: Path, rng: np.random.Generator) -> None:
    """Delete or replace one dataset, group or attribute, or make a dataset NaN."""
    if path.suffix == ".h5":
        import h5py

        with h5py.File(path, "r+") as f:
            names: list[str] = []
            f.visit(names.append)
            name = names[rng.integers(len(names))]
            op = rng.integers(5)
            if op == 0:
                del f[name]
            elif op == 1 and isinstance(f[name], h5py.Dataset) and f[name].dtype.kind == "f":
                f[name][...] = np.nan
            elif op == 2:
                del f[name]
                f[name] = rng.choice([np.arange(3.0), np.array("text"), np.zeros((2, 2), int)])
            elif op == 3 and f.attrs:
                key = list(f.attrs)[rng.integers(len(f.attrs))]
                f.attrs[key] = rng.choice(["x", -1, 1e300, np.nan])
            elif op == 4 and isinstance(f[name], h5py.Dataset) and f[name].maxshape[0] is None:
                f[name].resize(int(rng.integers(0, f[name].shape[0] + 1)), axis=0)
    else:
        import netCDF4

        with netCDF4.Dataset(path, "r+") as nc:
            op = rng.integers(3)
            names = list(nc.variables)
            if op == 0 and nc.ncattrs():
                nc.delncattr(nc.ncattrs()[rng.integers(len(nc.ncattrs()))])
            elif op == 1:
                v = nc.variables[names[rng.integers(len(names))]]
                if v.dtype.kind == "f" and v.size:
                    v[...] = np.nan
            elif nc.ncattrs():
                nc.setncattr(nc.ncattrs()[rng.integers(len(nc.ncattrs()))], "x")


@st.composite
def damaged_files(draw) -> tuple[str, bytes]:
    name = draw(st.sampled_from(["out.h5", "out.h5", "w.nc", "e.nc", "g.nc"]))
    data = bytearray(sources()[name])
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["flip_head", "flip_any", "cut", "grow", "zero",
                                 "structure", "structure"]))
    if kind == "flip_head":
        for i in rng.integers(0, min(len(data), 4096), rng.integers(1, 8)):
            data[i] ^= 1 << int(rng.integers(8))
    elif kind == "flip_any":
        for i in rng.integers(0, len(data), rng.integers(1, 40)):
            data[i] = int(rng.integers(256))
    elif kind == "cut":
        data = data[:int(rng.integers(0, len(data)))]
    elif kind == "grow":
        data += bytes(rng.integers(0, 256, int(rng.integers(1, 5000)), dtype=np.uint8))
    elif kind == "zero":
        a, n = int(rng.integers(0, len(data))), int(rng.integers(1, 2048))
        data[a:a + n] = bytes(len(data[a:a + n]))
    else:
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / name
            p.write_bytes(bytes(data))
            try:
                _structural(p, rng)
            except Exception:  # noqa: BLE001 - a mutation the library refuses: keep the copy
                pass
            data = bytearray(p.read_bytes())
    return name, bytes(data)


def check_reader(name: str, data: bytes) -> None:
    damaged = "in" + Path(name).suffix
    files = {damaged: data, "scene.toml": SCENE}
    cmds = [["plot", damaged, "--no-animation", "--out-dir", "pics"],
            ["export", damaged, "--out", "x.nc"],
            ["grid", damaged, "--out", "x.grid.nc", *GRID_ARGS], ["info", damaged]]
    if name == "out.h5":
        cmds.append(["run", "scene.toml", "--restart", damaged, "--out", "r.h5",
                     "--no-progress", "--no-plots"])
    for args in cmds:
        def unchanged(d: Path) -> None:
            got = (d / damaged).read_bytes()
            assert len(got) == len(data) and got[48:] == data[48:], (
                f"{' '.join(args)} changed the file it read")

        rc, err = run_checked(args, files, f"{' '.join(args)} of a damaged {name}", unchanged)
        one_line(rc, err)
        COUNT["reads"] += 1
    if name.endswith(".h5"):
        import xarray as xr

        from siku_core import SikuError

        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / damaged
            p.write_bytes(data)
            try:
                xr.open_dataset(p, engine="siku").close()
            except SikuError as exc:
                assert "\n" not in str(exc) and damaged in str(exc), exc
            assert p.read_bytes()[48:] == data[48:], "the reader changed the file"
    COUNT["readers"] += 1


def test_readers_never_change_the_file_they_read(tmp_path, monkeypatch):
    """Every command above on a foreign and on a damaged file leaves its bytes as they were
    (past the superblock, whose open-for-writing mark siku may clear on its own output)."""
    from siku_core.run.cli import main

    monkeypatch.chdir(tmp_path)
    Path("scene.toml").write_text(SCENE, encoding="utf-8")
    data = bytearray(sources()["out.h5"])
    data[len(data) // 2:len(data) // 2 + 64] = bytes(64)
    for name, content in (("d.h5", bytes(data)), ("f.h5", sources()["e.nc"]),
                          ("g.nc", sources()["out.h5"][:3000])):
        Path(name).write_bytes(content)
        for args in (["plot", name, "--no-animation"], ["export", name, "--out", "x.nc"],
                     ["grid", name, "--out", "y.nc", *GRID_ARGS],
                     ["run", "scene.toml", "--restart", name, "--out", "r.h5",
                      "--no-progress"]):
            main(args)
            assert Path(name).read_bytes() == content, args


@settings(max_examples=READERS, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(damaged_files())
def test_damaged_files_are_read_or_refused_in_one_line(case):
    check_reader(*case)


@pytest.mark.slow
@settings(max_examples=READERS_LONG, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(damaged_files())
def test_damaged_files_long(case):
    check_reader(*case)


@pytest.mark.slow
def test_fuzzed_files_long_count(capsys):
    """Runs after the long tests above (file order) and reports their counts."""
    with capsys.disabled():
        print(f"\nfuzz: {COUNT['sweeps']} sweeps and {COUNT['readers']} damaged files "
              f"({COUNT['reads']} reads), none with a traceback or a hang")
    assert COUNT["sweeps"] >= SWEEPS_LONG and COUNT["readers"] >= READERS_LONG


def test_a_library_crash_while_identifying_a_file_is_not_a_crash_of_siku():
    """The NetCDF and HDF5 libraries can die of a segmentation fault on a damaged file (the
    slow reader fuzz found one in netCDF4.Dataset): identification runs in a child process, so
    a crash there answers "not identified" and siku goes on to refuse the file in one line."""
    import ctypes

    from siku_io.output.marks import in_child

    assert in_child(lambda: "grid") == "grid" and in_child(lambda: None) is None
    assert in_child(lambda: ctypes.string_at(0)) is None  # the child dies of SIGSEGV
    assert in_child(lambda: 1 / 0) is None
    assert in_child(lambda: __import__("time").sleep(30), timeout=0.5) is None


def test_an_interrupted_identification_leaves_no_child_behind():
    """A wait cut short (Ctrl-C, a caller's alarm) kills the child: the slow fuzz's time limit
    had left children reading a damaged file for ever."""
    import signal
    import time

    import psutil

    from siku_io.output.marks import in_child

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    before = {c.pid for c in psutil.Process().children()}
    old = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 0.3)
    try:
        with pytest.raises(KeyboardInterrupt):
            in_child(lambda: time.sleep(30), timeout=20)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert {c.pid for c in psutil.Process().children()} <= before


@pytest.mark.parametrize("command", ["plot", "export", "grid", "restart", "info"])
def test_a_damaged_attribute_that_hangs_the_hdf5_library_is_refused(tmp_path, command):
    """``tests/data/damaged_attribute_hangs_hdf5.h5``: a siku output damaged by the slow
    reader fuzz. Its marks read well, but reading the attributes of its ``/geometry`` datasets
    never returns (H5HG__cache_heap_deserialize loops), and a reader hung in this process where
    no alarm reaches it. Every attribute is now read in the identifying child, which is given
    up after its time limit (set to 2 s here), so each command ends, in one line."""
    import shutil
    import subprocess
    import sys

    shutil.copy(Path(__file__).parent / "data" / "damaged_attribute_hangs_hdf5.h5",
                tmp_path / "in.h5")
    (tmp_path / "scene.toml").write_text(SCENE, encoding="utf-8")
    args = {"plot": ["plot", "in.h5", "--no-animation", "--out-dir", "pics"],
            "export": ["export", "in.h5", "--out", "x.nc"],
            "grid": ["grid", "in.h5", "--out", "g.nc", *GRID_ARGS],
            "restart": ["run", "scene.toml", "--restart", "in.h5", "--out", "r.h5",
                        "--no-progress", "--no-plots"], "info": ["info", "in.h5"]}[command]
    code = ("import sys\nfrom siku_io.output import marks\nmarks.in_child.__defaults__ = (2.0,)\n"
            "from siku_core.run.cli import main\nsys.exit(main(sys.argv[1:]))\n")
    r = subprocess.run([sys.executable, "-c", code, *args], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120)
    one_line(r.returncode, r.stderr)
    assert r.returncode == 2 and "in.h5" in r.stderr
