"""Ensembles on Dask: every member of a sweep (``siku_io.ensemble.sweep``) run as a task on a Dask
distributed cluster, and a summary dataset (xarray, one dimension per axis, written as NetCDF).

.. code-block:: python

    from siku_io.ensemble import runs

    ds = runs.run("rheology.toml")          # a local cluster, one worker per core
    ds["joints_broken"].sel(law="mohr_coulomb")

* Each member runs exactly as ``siku run BASE --set KEY=VALUE ... --out OUTPUT`` would
  (``ds.command`` holds that line): its output file is the same, byte for byte.
* A member that fails (a bad combination of values, a diverging run, a lost worker) gets status
  ``failed`` and its one-line message; the others go on.
* Running a sweep again skips members whose output is complete (status ``reused``), continues
  those an interruption cut short from their last snapshot (a bit-for-bit restart), and runs
  the rest. An output that holds another scene's run is never touched (the member fails,
  naming it).
* The summary (``[summary]`` of the sweep: final values and time series of any diagnostic a
  run reports, and ``mean_drift``, the mean distance [m] the free elements moved since the
  first snapshot) is written to ``OUT_DIR/summary.nc`` with the sweep text, the base scene and
  the versions in its attributes.

Where the members run: a local cluster (``distributed.LocalCluster``: one worker process per
core, one task at a time per worker, numba threads per member = cores / workers, so the machine
is never oversubscribed), or an existing cluster (``scheduler = ADDRESS``; on an HPC system,
start one with dask-jobqueue, docs/howto/ensembles.md). ``scheduler="serial"`` runs the members
one after another in this process (no Dask; what ``bench`` compares against).
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, Mapping

from siku_core import __version__
from siku_core.errors import DataError, SceneError, SikuError
from siku_core.run.outputs import check_target
from siku_io.ensemble.summary import summarize, write_summary
from siku_io.ensemble.sweep import Member, Sweep, load_sweep, sweep_from_text


# ---------------------------------------------------------------------------- one member
def run_member(scene_path: str, overrides: dict[str, str], output: str, restart: bool,
               threads: int | None) -> dict[str, Any]:
    """Run one member (in a Dask worker or in this process): the scene at ``scene_path`` with
    ``overrides`` (``--set``), written to ``output``; with ``restart`` continued from the last
    snapshot of ``output``. Never raises: a failure is returned as ``status = "failed"`` with a
    one-line ``message``."""
    t0 = time.perf_counter()
    before = None
    try:
        import numba

        from siku_core.scene.scene_file import load_scene
        from siku_core.run.simulation import Simulation

        if threads is not None:
            before = numba.get_num_threads()
            numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
        scene = load_scene(scene_path, overrides)
        sim = Simulation(scene, out=output, progress=False,
                         restart=output if restart else None)
        first = sim.step_index
        sim.run()
        return {"status": "done", "message": "restarted at step %d" % first if restart else "",
                "wall_time": time.perf_counter() - t0, "steps": sim.step_index - first}
    except SikuError as exc:
        msg = " | ".join(str(exc).splitlines())
    except Exception as exc:  # a member's bug must not stop the others: report it
        msg = f"{type(exc).__name__}: {' | '.join(str(exc).splitlines())}"
    finally:
        if before is not None:
            import numba

            numba.set_num_threads(before)
    return {"status": "failed", "message": msg, "wall_time": time.perf_counter() - t0,
            "steps": 0}


def plan(sweep: Sweep) -> dict[str, dict[str, Any]]:
    """What each member needs, by name: ``{"action": "run" | "restart" | "reuse" | "fail",
    "message": ...}``, from its scene (validated, components checked) and its output file."""
    from siku_core.run.limits import check_components
    from siku_io.output.results import run_progress

    out: dict[str, dict[str, Any]] = {}
    for m in sweep.members:
        try:
            scene = m.scene(sweep.scene_text)
            check_components(scene)
        except SikuError as exc:
            out[m.name] = {"action": "fail", "message": " | ".join(str(exc).splitlines())}
            continue
        if not m.output.exists():
            out[m.name] = {"action": "run", "message": ""}
            continue
        try:
            prog = run_progress(m.output)
        except (SikuError, OSError, KeyError) as exc:
            out[m.name] = {"action": "fail", "message": f"{m.output}: exists and is not an "
                           f"output of this member ({exc}); move it away to run the member"}
            continue
        sha = hashlib.sha256(scene.text.encode()).hexdigest()
        if prog["scene_sha256"] != sha:
            out[m.name] = {"action": "fail", "message": f"{m.output}: holds a run of another "
                           "scene (the sweep or its base scene changed); move it away to run "
                           "the member again"}
        elif prog["complete"]:
            out[m.name] = {"action": "reuse", "message": "complete output from an earlier run"}
        else:
            out[m.name] = {"action": "restart", "message": ""}
    return out


# ---------------------------------------------------------------------------- the cluster
def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _connect(client_cls, address: str, timeout: float, where: str):
    """A client of the Dask scheduler at ``address``, within ``timeout`` [s] whatever answers
    there: the connection is made in a thread given up after the timeout (a server that accepts
    and never speaks Dask's protocol would hold it for ever), and any failure, a reply read as
    an absurd size included, is a one-line :class:`SceneError` naming ``where``."""
    import threading

    box: dict[str, Any] = {}

    def connect() -> None:
        try:
            box["client"] = client_cls(address, timeout=timeout)
        except BaseException as exc:  # noqa: BLE001 - reported below, in one line
            box["error"] = exc

    t = threading.Thread(target=connect, name="siku-dask-connect", daemon=True)
    t.start()
    t.join(timeout + 2.0)
    why = None
    if t.is_alive():
        why = "no answer in Dask's protocol: is it a Dask scheduler?"
    elif isinstance(box.get("error"), MemoryError):
        why = ("the reply is not Dask's protocol (its length field read as an impossible "
               "size): is it a Dask scheduler?")
    elif "error" in box:
        exc = box["error"]
        why = f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
    if why is not None:
        raise SceneError(f"{where}: cannot reach the Dask scheduler at {address!r} within "
                         f"{timeout:g} s ({why})")
    return box["client"]


class _Cluster:
    """A Dask client on a local cluster or at ``scheduler``; closed on exit."""

    def __init__(self, sweep: Sweep, scheduler: str | None, workers: int | None,
                 threads: int | None):
        import logging

        from distributed import Client, LocalCluster

        cfg = sweep.cfg.cluster
        address = scheduler or cfg.scheduler
        self.cluster = None
        if address:
            self.client = _connect(Client, address, cfg.timeout, "--scheduler" if scheduler
                                   else f"{sweep.label} [cluster] key 'scheduler'")
            self.threads = threads or cfg.threads or 1
            return
        n = workers or cfg.workers or _cores()
        self.threads = threads or cfg.threads or max(1, _cores() // n)
        env = {"NUMBA_NUM_THREADS": str(max(self.threads, 1)), "OMP_NUM_THREADS": "1"}
        self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                    dashboard_address=None, silence_logs=logging.ERROR, env=env)
        self.client = Client(self.cluster)
        self.pids = [int(p) for p in self.client.run(os.getpid).values()]

    def stop_members(self, futures) -> None:
        """After an interruption: cancel what has not run; on a local cluster also stop the
        members running now (their worker processes are ended: each member's output keeps its
        last complete snapshot, from which a rerun of the sweep continues)."""
        try:
            self.client.cancel(list(futures), force=True)
        except Exception:  # noqa: BLE001 - the cluster may already be going down
            pass
        if self.cluster is None:
            return
        import psutil

        procs = []
        for pid in self.pids:  # the worker processes of our own local cluster
            try:
                procs.append(psutil.Process(pid))
            except psutil.Error:
                pass
        for p in procs:
            try:
                p.terminate()
            except psutil.Error:
                pass
        _, alive = psutil.wait_procs(procs, timeout=5)
        for p in alive:
            try:
                p.kill()
            except psutil.Error:
                pass

    def close(self) -> None:
        try:
            self.client.close(timeout=10)
        finally:
            if self.cluster is not None:
                self.cluster.close(timeout=10)


# ---------------------------------------------------------------------------- running
def _as_sweep(sweep: Sweep | str | Path | Mapping[str, Any], out_dir) -> Sweep:
    if isinstance(sweep, Sweep):
        return sweep
    if isinstance(sweep, Mapping):
        from siku_io.ensemble.sweep import toml_value

        lines = []
        tables = {}
        for k, v in sweep.items():
            if isinstance(v, Mapping):
                tables[k] = v
            elif isinstance(v, list) and v and all(isinstance(x, Mapping) for x in v):
                tables[k] = v
            else:
                lines.append(f"{k} = {toml_value(v)}")
        for k, v in tables.items():
            for t in (v if isinstance(v, list) else [v]):
                lines.append(f"[[{k}]]" if isinstance(v, list) else f"[{k}]")
                lines += [f"{json.dumps(str(a))} = {toml_value(b)}" for a, b in t.items()]
        return sweep_from_text("\n".join(lines) + "\n", "<sweep>", Path.cwd(), out_dir)
    return load_sweep(sweep, out_dir)


def _check_summary_target(sweep: Sweep) -> None:
    """The summary file may be replaced only if it is an earlier summary of this very sweep
    (the same sweep text, base scene and folder); never a device, FIFO or folder."""
    from siku_io.output.marks import netcdf_kind

    path = sweep.summary_path
    where = f"{sweep.label} [summary] key 'file'"
    try:
        check_target(path, what="summary", option=where)
    except DataError as exc:
        if not path.is_file():  # a folder, a device, a FIFO
            raise SceneError(f"{where}: {exc}") from None
    if not path.exists():
        return
    ok = False
    if netcdf_kind(path) == "summary":
        try:
            import netCDF4

            with netCDF4.Dataset(path) as nc:
                ok = (getattr(nc, "sweep_out_dir", "") == str(sweep.out_dir)
                      and getattr(nc, "sweep", "") == sweep.text
                      and getattr(nc, "scene", "") == sweep.scene_text)
        except (OSError, RuntimeError):
            ok = False
    if not ok:
        raise SceneError(f"{where}: {path} exists and is not a summary of this sweep (the "
                         "sweep or its base scene changed, or siku did not write it); move it "
                         "away or name another file")


def _make_out_dir(sweep: Sweep) -> None:
    try:
        sweep.out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError(f"{sweep.label} [out_dir]: {sweep.out_dir}: cannot be made a folder "
                         f"({exc.strerror}); name a folder (or give --out-dir)") from None


def run(sweep: Sweep | str | Path | Mapping[str, Any], *, scheduler: str | None = None,
        workers: int | None = None, threads: int | None = None, out_dir=None,
        progress: bool | None = None, write: bool = True, on_start=None):
    """Run every member of ``sweep`` (a sweep file, a :class:`~siku_io.ensemble.sweep.Sweep`, or the
    sweep as a dict) and return the summary dataset (``xarray.Dataset``).

    scheduler : a Dask scheduler address, ``"serial"`` (one after another in this process),
        or ``None``: the sweep's ``[cluster] scheduler``, else a local cluster.
    workers : worker processes of a local cluster (default: the sweep's, else one per core).
    threads : numba threads per member (default: the sweep's, else cores / workers).
    out_dir : overrides the sweep's ``out_dir``.
    progress : a progress bar over the members (``None``: when stderr is a terminal).
    write : write the summary to its NetCDF file.
    on_start : called with the plan (``{member name: action}``) once the members can start
        (the cluster is up).
    """
    sw = _as_sweep(sweep, out_dir)
    if write:
        _check_summary_target(sw)
    _make_out_dir(sw)
    todo = plan(sw)
    results: dict[str, dict[str, Any]] = {}
    for m in sw.members:
        p = todo[m.name]
        if p["action"] in ("fail", "reuse"):
            results[m.name] = {"status": "failed" if p["action"] == "fail" else "reused",
                               "message": p["message"], "wall_time": math.nan, "steps": 0}
    jobs = [m for m in sw.members if todo[m.name]["action"] in ("run", "restart")]
    show = sys.stderr.isatty() if progress is None else progress
    from tqdm.auto import tqdm

    bar = tqdm(total=len(sw.members), unit="member", desc=sw.cfg.title or "ensemble",
               disable=not show, initial=len(sw.members) - len(jobs), file=sys.stderr,
               bar_format="{l_bar}{bar}| {n:.1f}/{total_fmt} members [{elapsed}<{remaining}]")
    actions = {m.name: todo[m.name]["action"] for m in sw.members}
    serial = (scheduler or sw.cfg.cluster.scheduler) == "serial" or not jobs
    # members of this process are not read while they write (HDF5 holds their files here)
    watch = MemberProgress(bar, jobs, results, files=not serial) if show else None
    if watch is not None:
        watch.start()

    def advance() -> None:
        bar.update(1) if watch is None else watch.poll()

    try:
        if serial:
            if on_start is not None:
                on_start(actions)
            for m in jobs:
                results[m.name] = run_member(str(m.scene_path), m.overrides, str(m.output),
                                             todo[m.name]["action"] == "restart", threads)
                advance()
        else:
            _run_dask(sw, jobs, todo, results, advance, scheduler, workers, threads,
                      lambda: on_start(actions) if on_start is not None else None)
    finally:
        if watch is not None:
            watch.stop()
        bar.close()
    ds = summarize(sw, results)
    if write:
        write_summary(ds, sw.summary_path)
    return ds


def _run_dask(sw: Sweep, jobs: list[Member], todo, results, advance, scheduler, workers,
              threads, started) -> None:
    from distributed import as_completed

    cl = _Cluster(sw, scheduler, workers, threads)
    futures: dict[Any, Member] = {}
    try:
        started()
        for m in jobs:
            fut = cl.client.submit(run_member, str(m.scene_path), m.overrides, str(m.output),
                                   todo[m.name]["action"] == "restart", cl.threads,
                                   key=f"siku-member-{m.name}-{sw.sha256[:12]}", pure=False,
                                   retries=0)
            futures[fut] = m
        for fut in as_completed(futures):
            m = futures[fut]
            try:
                results[m.name] = fut.result()
            except Exception as exc:  # a lost worker (killed, out of memory)
                results[m.name] = {"status": "failed", "wall_time": math.nan, "steps": 0,
                                   "message": f"{type(exc).__name__}: "
                                              f"{' '.join(str(exc).split())[:300]}"}
            advance()
    except KeyboardInterrupt:
        cl.stop_members(futures)
        raise
    finally:
        cl.close()


class MemberProgress:
    """The progress bar of an ensemble counts members in fractions: a running member counts
    the share of its steps its output file holds (the step of its last complete snapshot over
    the steps its scene asks for, read from the file as it is written, as ``siku info`` reads
    it), a finished one counts one. :meth:`start` polls every ``interval`` seconds [s] in a
    thread, so the bar moves (and its clock runs) while members run, not only when one ends.
    With ``files=False`` (members running in this process) only finished members count."""

    def __init__(self, bar, jobs: list[Member], results: Mapping[str, Any],
                 interval: float = 1.0, files: bool = True):
        import threading

        self.bar, self.jobs, self.results, self.interval = bar, jobs, results, interval
        self.files = files
        self._lock = threading.Lock()
        self.base = float(bar.n)  # members done before this run (reused, failed in the plan)
        self._stop = None
        self._thread = None

    @staticmethod
    def fraction(path) -> float:
        """The share [1] of its steps a member's output file holds (0 when it holds none or
        cannot be read yet)."""
        from siku_io.output.results import run_progress

        try:
            prog = run_progress(path)
        except Exception:  # noqa: BLE001 - a file being created, or a member that failed
            return 0.0
        return max(0.0, prog["step"]) / max(1, prog["n_steps"])

    def poll(self) -> float:
        """Set the bar to the members done so far, in fractions; returns that count."""
        with self._lock:
            done = self.base
            for m in self.jobs:
                if m.name in self.results:
                    done += 1.0
                elif self.files and Path(m.output).exists():
                    done += min(self.fraction(m.output), 0.999)  # one only when finished
            self.bar.n = done
            self.bar.refresh()
            return done

    def start(self) -> None:
        import threading

        self._stop = threading.Event()

        def loop() -> None:
            while not self._stop.wait(self.interval):
                self.poll()

        self._thread = threading.Thread(target=loop, name="siku-ensemble-progress",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None
        self.poll()


# ---------------------------------------------------------------------------- command line
def cmd_ensemble(args) -> int:
    """``siku ensemble SWEEP.toml``: exit 0 when every member is done, 1 when some failed
    (listed), 2 for a bad sweep file or an unreachable scheduler."""
    sw = load_sweep(args.sweep, args.out_dir)

    def started(actions: dict[str, str]) -> None:
        counts: dict[str, int] = {}
        for a in actions.values():
            counts[a] = counts.get(a, 0) + 1
        print(f"siku {__version__}: ensemble {sw.cfg.title or sw.label}: {len(sw.members)} "
              f"members ({' x '.join(f'{a.dim} {len(a)}' for a in sw.axes) or 'one scene'}); "
              + ", ".join(f"{n} to {k}" for k, n in sorted(counts.items())), file=sys.stderr)

    t0 = time.perf_counter()
    ds = run(sw, scheduler=args.scheduler, workers=args.workers, threads=args.threads,
             progress=False if args.no_progress else None, on_start=started)
    failed = [(str(o), str(msg)) for s, o, msg in zip(ds.status.values.ravel(),
                                                      ds.output.values.ravel(),
                                                      ds.message.values.ravel())
              if s == "failed"]
    for out, msg in failed:
        print(f"siku: member failed: {Path(out).stem}: {msg}", file=sys.stderr)
    print(f"done in {time.perf_counter() - t0:.1f} s: {len(sw.members) - len(failed)} of "
          f"{len(sw.members)} members complete; summary: {sw.summary_path}", file=sys.stderr)
    return 1 if failed else 0


__all__ = ["cmd_ensemble", "plan", "run", "run_member", "summarize", "write_summary"]
