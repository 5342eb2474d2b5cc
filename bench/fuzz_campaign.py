"""The slow fuzz campaigns, counted by outcome: generated scenes, damaged output files, sweeps and
runs killed with ``kill -9`` and continued with ``--restart``.

Every case runs in a forked child process with a time limit, so that one case that crashes the
interpreter (a signal) or never ends is counted, and the campaign goes on. The outcomes:

``ran``
    exit status 0 (1 for an ensemble with failed members);
``refused``
    exit status 2 with exactly one ``siku: error:`` line naming a file or an option;
``traceback``
    an exception out of the command, any other exit status, a traceback printed or a refusal
    that is not one line;
``hang``
    no end within the case's time limit;
``crash``
    the child died of a signal;
``foreign``
    a file the command did not create changed (the scene, the sweep, the file a reader reads:
    past the HDF5 superblock, whose open-for-writing mark siku may clear on its own output);
``wrong``
    wrong data: a scene that ran wrote a time axis that is not finite and rising, or a state
    that is not finite; a killed and continued run whose HDF5 file or further NetCDF file
    differs from the uninterrupted run's (time axis and every value, bit for bit).

The generators are the fuzz tests' own (``tests/test_fuzz_scenes.py``,
``tests/test_fuzz_files.py``), drawn by hypothesis with a fixed seed. Usage, from the
repository root (about half an hour for the default counts on a busy 2-core machine)::

    NUMBA_NUM_THREADS=1 nice -n 10 python -m bench.fuzz_campaign --scenes 300 --files 150 \\
        --sweeps 40 --restarts 40
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

OUTCOMES = ("ran", "refused", "traceback", "hang", "crash", "foreign", "wrong")
#: time limit of one case [s], beyond the fuzz tests' own alarm of 60 s
LIMIT = 180.0


def in_fork(fn: Callable[[], dict], limit: float = LIMIT) -> dict:
    """``fn()`` (a dict with ``outcome``) in a forked child; ``crash`` when it dies of a signal,
    ``hang`` when it outlives ``limit`` [s] (then killed)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        try:
            os.close(r)
            try:
                res = fn()
            except BaseException as exc:  # noqa: BLE001 - counted, with its last lines
                res = {"outcome": "traceback",
                       "detail": "".join(traceback.format_exception(exc))[-1500:]}
            os.write(w, json.dumps(res, default=str).encode())
        finally:
            os._exit(0)
    os.close(w)
    deadline, status = time.monotonic() + limit, None
    chunks = []
    try:
        while status is None and time.monotonic() < deadline:
            done, st = os.waitpid(pid, os.WNOHANG)
            if done:
                status = st
            else:
                time.sleep(0.01)
        if status is not None:
            while chunk := os.read(r, 1 << 16):
                chunks.append(chunk)
    finally:
        os.close(r)
        if status is None:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
    if status is None:
        return {"outcome": "hang", "detail": f"no end after {limit:g} s"}
    if os.WIFSIGNALED(status):
        return {"outcome": "crash", "detail": f"signal {os.WTERMSIG(status)}"}
    try:
        return json.loads(b"".join(chunks).decode())
    except ValueError:
        return {"outcome": "crash", "detail": "no answer from the child"}


def judged(rc: int, err: str, allowed=(0,)) -> str:
    """The outcome of a command's exit status and error output."""
    if "Traceback" in err:
        return "traceback"
    if rc in allowed:
        return "ran"
    if rc == 2:
        lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
        names = (".toml", ".h5", ".nc", ".npz", ".png", ".gif", "--", "ens")
        if len(lines) == 1 and any(s in lines[0] for s in names):
            return "refused"
    return "traceback"


def output_is_sound(path: Path) -> str | None:
    """``None`` when a finished run's HDF5 output holds a finite, rising time axis and finite
    states; else what is wrong."""
    import h5py
    import numpy as np

    from siku_io.output.results import n_snapshots, open_results

    with open_results(path) as f:
        n = n_snapshots(f)
        t = f["states/time"][:n]
        if not np.isfinite(t).all() or (np.diff(t) <= 0).any():
            return f"time axis {t[:8].tolist()}..."
        for k in ("q", "V", "w"):
            if k in f["states"] and isinstance(f["states"][k], h5py.Dataset):
                if not np.isfinite(f["states"][k][:n]).all():
                    return f"non-finite states/{k}"
    return None


# ------------------------------------------------------------------ the four campaigns
def scene_case(text: str) -> dict:
    import test_fuzz_scenes as fs

    seen: dict[str, Any] = {}

    def after(d: Path) -> None:
        seen["scene"] = (d / "scene.toml").read_text(encoding="utf-8")
        out = d / "out.h5"
        seen["wrong"] = output_is_sound(out) if out.is_file() else None

    try:
        rc, err = fs.run_main(["run", "scene.toml", "--out", "out.h5", "--no-progress",
                               "--no-plots"], {"scene.toml": text}, after)
    except fs.Hang as exc:
        return {"outcome": "hang", "detail": str(exc)}
    outcome = judged(rc, err)
    if seen.get("scene") != text:
        outcome = "foreign"
    elif outcome == "ran" and seen.get("wrong"):
        outcome = "wrong"
    return {"outcome": outcome, "detail": err[-600:] if outcome != "ran" else ""}


def file_case(name: str, data: bytes) -> dict:
    import test_fuzz_files as ff
    import test_fuzz_scenes as fs

    damaged = "in" + Path(name).suffix
    cmds = [["plot", damaged, "--no-animation", "--out-dir", "pics"],
            ["export", damaged, "--out", "x.nc"],
            ["grid", damaged, "--out", "x.grid.nc", *ff.GRID_ARGS], ["info", damaged]]
    if name == "out.h5":
        cmds.append(["run", "scene.toml", "--restart", damaged, "--out", "r.h5",
                     "--no-progress", "--no-plots"])
    worst = "ran"
    order = {k: i for i, k in enumerate(OUTCOMES)}
    details = []
    for args in cmds:
        same: dict[str, bool] = {}

        def after(d: Path) -> None:
            got = (d / damaged).read_bytes()
            same["ok"] = len(got) == len(data) and got[48:] == data[48:]

        try:
            rc, err = fs.run_main(args, {damaged: data, "scene.toml": ff.SCENE}, after)
            outcome = judged(rc, err)
        except fs.Hang as exc:
            outcome, err = "hang", str(exc)
        if not same.get("ok", True):
            outcome = "foreign"
        if outcome not in ("ran", "refused"):
            details.append(f"{' '.join(args)}: {err[-400:]}")
        if order[outcome] > order[worst]:
            worst = outcome
    return {"outcome": worst, "detail": " | ".join(details)}


def sweep_case(text: str) -> dict:
    import test_fuzz_files as ff
    import test_fuzz_scenes as fs

    seen: dict[str, str] = {}

    def after(d: Path) -> None:
        seen["sweep"] = (d / "sweep.toml").read_text(encoding="utf-8")
        seen["scene"] = (d / "scene.toml").read_text(encoding="utf-8")

    try:
        rc, err = fs.run_main(["ensemble", "sweep.toml", "--no-progress"],
                              {"sweep.toml": text, "scene.toml": ff.SCENE}, after)
    except fs.Hang as exc:
        return {"outcome": "hang", "detail": str(exc)}
    outcome = judged(rc, err, allowed=(0, 1))
    if seen.get("sweep") != text or seen.get("scene") != ff.SCENE:
        outcome = "foreign"
    return {"outcome": outcome, "detail": err[-600:] if outcome != "ran" else ""}


RESTART_SCENE: str = ""


def restart_scene(netcdf: bool) -> str:
    """Three 2 km floes at 80°N under Coriolis, two of them colliding (the restart property
    test's scene) at 1 s steps for an hour, a snapshot a minute; a NetCDF writer beside."""
    from siku_core.testing import scene_text
    from test_restart_property import DLON, SIZE

    els = [{"center": (0.0, 80.0), "velocity": (0.01, 0.002), "thickness": 1.0},
           {"center": (1.05 * DLON, 80.0), "velocity": (-0.01, 0.0), "thickness": 1.0},
           {"center": (0.5 * DLON, 80.0 + 1.2 * SIZE / 111195.0), "spin": 1e-5,
            "thickness": 1.0}]
    extra = '[[output.extra]]\nwriter = "netcdf"\nfile = "a.nc"\n' if netcdf else ""
    return scene_text(els, size=SIZE, dt=1.0, duration=3600.0,
                      forcing=[{"source": "coriolis"}],
                      output={"file": "run.h5", "every": 60.0}, extra=extra)


def siku_cmd(args: list[str], cwd: Path, threads: int) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": str(threads)}
    return subprocess.run([sys.executable, "-m", "siku_core.run.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=LIMIT - 20)


def arrays(d: Path, netcdf: bool) -> dict[str, Any]:
    import h5py
    import netCDF4
    import numpy as np

    out: dict[str, Any] = {}
    with h5py.File(d / "run.h5", "r") as f:
        for k in ("time", "step", "q", "V", "w"):
            out[f"h5/{k}"] = f[f"states/{k}"][:]
    if netcdf:
        with netCDF4.Dataset(d / "a.nc") as nc:
            for k, v in nc.variables.items():
                if v.dimensions[:1] == ("time",):
                    out[f"nc/{k}"] = np.ma.filled(v[:].astype(float), np.nan)
    return out


def restart_case(netcdf: bool, delay: float, threads: int, ref: dict[str, Any]) -> dict:
    import numpy as np

    with tempfile.TemporaryDirectory() as dd:
        d = Path(dd)
        text = restart_scene(netcdf)
        (d / "s.toml").write_text(text, encoding="utf-8")
        env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": str(threads)}
        p = subprocess.Popen([sys.executable, "-m", "siku_core.run.cli", "run", "s.toml",
                              "--no-progress", "--no-plots"], cwd=d, env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t0 = time.monotonic()
        while not (d / "run.h5").exists() and p.poll() is None and time.monotonic() - t0 < 120:
            time.sleep(0.005)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.wait()
        if not (d / "run.h5").exists():  # killed before its first snapshot: run it again
            r = siku_cmd(["run", "s.toml", "--no-progress", "--no-plots"], d, threads)
        else:
            r = siku_cmd(["run", "s.toml", "--restart", "run.h5", "--no-progress",
                          "--no-plots"], d, threads)
            if r.returncode == 2 and "already complete" in r.stderr:
                r = subprocess.CompletedProcess(r.args, 0, "", "")
        outcome = judged(r.returncode, r.stderr)
        if (d / "s.toml").read_text(encoding="utf-8") != text:
            return {"outcome": "foreign", "detail": "the scene changed"}
        if outcome != "ran":
            return {"outcome": outcome, "detail": r.stderr[-600:]}
        got = arrays(d, netcdf)
        for k, a in ref.items():
            if k not in got or got[k].shape != a.shape or not np.array_equal(
                    got[k], a, equal_nan=True):
                return {"outcome": "wrong", "detail": f"{k} differs from the uninterrupted run"}
    return {"outcome": "ran", "detail": ""}


def references() -> dict[bool, dict[str, Any]]:
    """The uninterrupted runs (with and without the NetCDF writer)."""
    refs = {}
    for netcdf in (False, True):
        with tempfile.TemporaryDirectory() as dd:
            d = Path(dd)
            (d / "s.toml").write_text(restart_scene(netcdf), encoding="utf-8")
            r = siku_cmd(["run", "s.toml", "--no-progress", "--no-plots"], d, 1)
            assert r.returncode == 0, r.stderr
            refs[netcdf] = arrays(d, netcdf)
    return refs


def made_apart(ff) -> None:
    """The fuzz tests' source files (``test_fuzz_files.sources``) made by another process and
    read here: this process forks every case, and numba's OpenMP layer ends a forked child that
    runs parallel code when the parent ran some before the fork; so this one runs none."""
    with tempfile.TemporaryDirectory() as d:
        code = ("import sys, pathlib\nsys.path.insert(0, sys.argv[1])\n"
                "import test_fuzz_files as ff\nfor k, v in ff.sources().items():\n"
                "    pathlib.Path(sys.argv[2], k).write_bytes(v)\n")
        subprocess.run([sys.executable, "-c", code, str(ROOT / "tests"), d], check=True,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True,
                       timeout=600)
        for f in Path(d).iterdir():
            ff._SOURCES[f.name] = f.read_bytes()


# ------------------------------------------------------------------ driving
def campaign(name: str, n: int, strategy, case: Callable[..., dict], log) -> dict[str, int]:
    """``n`` cases drawn from the hypothesis ``strategy`` (fixed seed), each run by ``case`` in
    a forked child; counts by outcome."""
    from hypothesis import HealthCheck, given, settings

    counts = dict.fromkeys(OUTCOMES, 0)

    @settings(max_examples=n, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(strategy)
    def each(drawn):
        args = drawn if isinstance(drawn, tuple) else (drawn,)
        res = in_fork(lambda: case(*args))
        counts[res["outcome"]] += 1
        if res["outcome"] not in ("ran", "refused"):
            log.write(json.dumps({"campaign": name, "case": repr(args)[:3000], **res}) + "\n")
            log.flush()

    each()
    return counts


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=300)
    ap.add_argument("--files", type=int, default=150)
    ap.add_argument("--sweeps", type=int, default=40)
    ap.add_argument("--restarts", type=int, default=40)
    ap.add_argument("--log", default="fuzz_campaign.jsonl",
                    help="the cases that neither ran nor were refused in one line, as JSON lines")
    a = ap.parse_args(argv)
    from hypothesis import strategies as st

    import test_fuzz_files as ff
    import test_fuzz_scenes as fs

    made_apart(ff)  # the files to damage, made in another process (see made_apart)
    total = dict.fromkeys(OUTCOMES, 0)
    with open(a.log, "w", encoding="utf-8") as log:
        plan = [("scenes", a.scenes, fs.scenes(), scene_case),
                ("damaged files", a.files, ff.damaged_files(), file_case),
                ("sweeps", a.sweeps, ff.sweeps(), sweep_case)]
        if a.restarts:
            refs = references()
            plan.append(("restarts", a.restarts, st.tuples(
                st.booleans(), st.floats(0.0, 3.0), st.sampled_from([1, 2])),
                lambda netcdf, delay, threads: restart_case(netcdf, delay, threads,
                                                            refs[netcdf])))
        for name, n, strategy, case in plan:
            if not n:
                continue
            t0 = time.monotonic()
            c = campaign(name, n, strategy, case, log)
            for k in OUTCOMES:
                total[k] += c[k]
            print(f"{name}: {sum(c.values())} cases, " + ", ".join(f"{c[k]} {k}" for k in
                                                                   OUTCOMES)
                  + f" ({time.monotonic() - t0:.0f} s)", flush=True)
    print(f"all: {sum(total.values())} cases, " + ", ".join(f"{total[k]} {k}" for k in
                                                            OUTCOMES), flush=True)
    return 0 if all(total[k] == 0 for k in OUTCOMES[2:]) else 1


if __name__ == "__main__":
    sys.exit(main())
