"""The writer conformance suite: checks any writer (``siku_core.interfaces.Writer``), built-in
or third-party, must pass, found by its name in the registry (a new writer needs no change here).

.. code-block:: python

    from siku_core.testing.writer_checks import check_writer

    def test_my_writer_conforms(tmp_path):
        check_writer("my_writer", tmp_path)

Each check runs the suite's scene (two free-drifting square elements of 10 km, no contacts and no
forcing; 10 steps of 60 s, a snapshot every 2 steps: 6 snapshots) through the engine with the
writer as ``[output] writer`` and raises ``AssertionError`` saying what failed:

* :func:`check_writer_publish`: the file is built elsewhere and appears at its path only with
  its first snapshot, and nothing is left beside it after the run (``siku_core.run.outputs``:
  ``partial_path``, ``publish``); a run stopped before its first snapshot leaves nothing, and
  an old file given to ``overwrite`` stays byte for byte what it was;
* :func:`check_writer_owns`: :meth:`~siku_core.interfaces.Writer.owns` claims the writer's own
  output and no other file (a text file, an empty file, random bytes), and reads without
  writing;
* :func:`check_writer_overwrite`: an existing output is refused without ``overwrite``; with it,
  the new file holds the new run's snapshots only, and a file the writer does not own is never
  replaced;
* :func:`check_writer_restart`: a writer whose files restart (``read_restart``) gives the last
  snapshot bit for bit, and the run continued from the middle of the run holds the snapshots
  of the run that never stopped, no row twice and none extra (continued in the same file when
  the writer ``appends``, else in a new one); a writer whose files cannot be restarted refuses
  in one line (a :class:`~siku_core.errors.DataError` naming the file).

The snapshot steps of a file are read by ``steps(path)`` (default :func:`snapshot_steps`: the
``step`` variable of the file opened by ``xarray.open_dataset``, whose engines read siku's HDF5
output, NetCDF and Zarr stores); a writer whose files xarray cannot open passes its own reader.

Cost: about 10 short runs of two elements; 2-5 s per writer once the engine's kernels are in
the cache (``~/.cache/siku``), plus their first compilation (about a minute) in a fresh
environment.
"""
from __future__ import annotations

import hashlib
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError
from ..plugins import Registry, get_registry
from ..scene.scene_file import scene_from_text
from .contact_cases import registry_with
from .scenes import scene_text

#: the suite's scene: steps, step [s], snapshot every that many steps
STEPS, DT, EVERY = 10, 60.0, 2

Steps = Callable[[Path], Sequence[int]]


class StopBeforeFirstSnapshot(Exception):
    """Raised by the suite's spy in place of the first snapshot (a run killed before it)."""


def writer_scene_text(name: str, steps: int = STEPS, params: dict | None = None) -> str:
    """The suite's scene with writer ``name`` (``params``: its parameters) as ``[output]``."""
    output: dict[str, Any] = {"writer": name, "every": EVERY * DT, "file": "out"}
    if params:
        output["params"] = dict(params)
    return scene_text([{"center": (-150.0, 75.0), "velocity": (0.2, 0.05), "spin": 1e-5},
                       {"center": (-149.0, 75.2), "velocity": (-0.1, 0.15)}],
                      dt=DT, duration=steps * DT, output=output)


def snapshot_steps(path: Path) -> np.ndarray:
    """The steps of the complete snapshots of the output ``path``, in file order: the ``step``
    variable of ``xarray.open_dataset(path)`` (the engine xarray guesses, else the first
    installed engine that opens it), or of its ``states`` group."""
    import xarray as xr

    errors = []
    engines = [None, *(e for e in xr.backends.list_engines() if e != "store")]
    for engine in engines:  # the guess first (by content or name), then every engine
        for group in (None, "states"):
            try:
                with xr.open_dataset(path, engine=engine, group=group,
                                     decode_times=False) as ds:
                    if "step" in ds.variables:
                        return np.asarray(ds["step"].values).astype(np.int64)
            except Exception as exc:  # noqa: BLE001 - any engine's refusal: try the next
                errors.append(f"{engine or 'guessed'}: {type(exc).__name__}")
    raise AssertionError(f"{path}: xarray finds no 'step' variable in this output "
                         f"({'; '.join(errors) or 'none'}); pass steps=READER (the steps of the "
                         "file's complete snapshots) to the writer checks")


def fingerprint(path: Path) -> str | None:
    """A hash of the bytes at ``path`` (a file, or every file of a folder store with its
    relative name); ``None`` where nothing exists."""
    path = Path(path)
    if not path.exists():
        return None
    h = hashlib.sha256()
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    for p in files:
        h.update(str(p.relative_to(path) if p != path else "").encode() + b"\0")
        h.update(p.read_bytes())
    return h.hexdigest()


def _writer_class(name: str, registry: Registry | None) -> type:
    return (registry or get_registry()).get("writer", name)


def _spy(cls: type, log: list, stop_first: bool = False) -> type:
    """``cls`` noting what is at its path after ``open`` and around every snapshot."""

    class Spy(cls):
        def open(self, ctx: Any) -> None:
            super().open(ctx)
            log.append(("open", None, fingerprint(self.path)))

        def write_state(self, ctx: Any) -> None:
            if stop_first:
                raise StopBeforeFirstSnapshot(f"stopped before step {ctx.step_index}")
            before = fingerprint(self.path)
            super().write_state(ctx)
            log.append(("write", ctx.step_index, before, fingerprint(self.path)))

    Spy.__name__ = Spy.__qualname__ = cls.__name__
    Spy.__module__ = cls.__module__
    return Spy


def _simulation(cls: type, out: Path, registry: Registry | None = None, *,
                steps: int = STEPS, restart: Path | None = None, overwrite: bool = False,
                params: dict | None = None) -> Any:
    from ..run.simulation import Simulation

    scene = scene_from_text(writer_scene_text(cls.name, steps, params),
                            f"<writer conformance {cls.name}>")
    return Simulation(scene, out=out, restart=restart, overwrite=overwrite, progress=False,
                      registry=registry_with("writer", cls, registry))


def _expected(steps: int = STEPS, start: int = 0) -> list[int]:
    """The snapshot steps of a run of ``steps`` steps from ``start``: every ``EVERY`` steps
    and the last one."""
    on = [s for s in range(0, steps + 1, EVERY) if s >= start]
    return on if on and on[-1] == steps else [*on, steps]


def _check_steps(name: str, path: Path, want: list[int], steps: Steps, what: str) -> None:
    got = [int(s) for s in steps(path)]
    assert got == want, (f"writer '{name}': {what}: the file holds the snapshots of steps {got}, "
                         f"not {want}" + (" (a row written twice)" if len(set(got)) < len(got)
                                          else ""))


def _leftovers(folder: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def check_writer_publish(name: str, tmp_path: Path, registry: Registry | None = None,
                         params: dict | None = None, steps: Steps = snapshot_steps) -> None:
    cls = _writer_class(name, registry)
    folder = Path(tmp_path) / f"publish_{name}"
    folder.mkdir()
    target = folder / "out"
    log: list = []
    _simulation(_spy(cls, log), target, registry, params=params).run()
    opened = [e for e in log if e[0] == "open"]
    writes = [e for e in log if e[0] == "write"]
    assert opened and opened[0][2] is None, (
        f"writer '{name}': {target.name} exists as soon as the writer opened it, before any "
        "snapshot: build the file at siku_core.run.outputs.partial_path(path) and publish it "
        "with its first snapshot")
    assert writes and writes[0][3] is not None, (
        f"writer '{name}': nothing at {target.name} after the first snapshot")
    assert cls.owns(target), f"writer '{name}': does not own the file it wrote"
    assert _leftovers(folder, {target.name}) == [], (
        f"writer '{name}': left {_leftovers(folder, {target.name})} beside its output")
    _check_steps(name, target, [e[1] for e in writes], steps, "an uninterrupted run")
    # stopped before the first snapshot: nothing left; an old file stays whole
    for old in (False, True):
        before = fingerprint(target)
        if not old:
            target_new = folder / "never"
        else:
            target_new = target
        try:
            _simulation(_spy(cls, [], stop_first=True), target_new, registry, overwrite=old,
                        params=params).run()
        except StopBeforeFirstSnapshot:
            pass
        else:
            raise AssertionError("the suite's stop before the first snapshot did not stop")
        if old:
            assert fingerprint(target) == before, (
                f"writer '{name}': a run given the old output to replace and stopped before "
                "its first snapshot changed the old file (it must stay whole until the new "
                "one holds a snapshot)")
        else:
            assert not target_new.exists(), (
                f"writer '{name}': a run stopped before its first snapshot left "
                f"{target_new.name} behind")
        assert _leftovers(folder, {target.name}) == [], (
            f"writer '{name}': a run stopped before its first snapshot left "
            f"{_leftovers(folder, {target.name})}")


def check_writer_owns(name: str, tmp_path: Path, registry: Registry | None = None,
                      params: dict | None = None) -> None:
    cls = _writer_class(name, registry)
    folder = Path(tmp_path) / f"owns_{name}"
    folder.mkdir()
    target = folder / "out"
    _simulation(cls, target, registry, params=params).run()
    before = fingerprint(target)
    assert cls.owns(target), f"writer '{name}': owns() does not claim its own output"
    assert fingerprint(target) == before, f"writer '{name}': owns() changed the file it read"
    rng = np.random.default_rng(0)
    foreign = {"text": b"time,lat,lon\n0,75,-150\n", "empty": b"",
               "random bytes": rng.integers(0, 256, 4096, dtype=np.uint8).tobytes()}
    for what, data in foreign.items():
        p = folder / f"foreign_{what.replace(' ', '_')}"
        p.write_bytes(data)
        assert not cls.owns(p), (
            f"writer '{name}': owns() claims a file it did not write ({what}): --overwrite "
            "would replace it")
        assert p.read_bytes() == data, f"writer '{name}': owns() changed a file ({what})"


def check_writer_overwrite(name: str, tmp_path: Path, registry: Registry | None = None,
                           params: dict | None = None, steps: Steps = snapshot_steps) -> None:
    cls = _writer_class(name, registry)
    folder = Path(tmp_path) / f"overwrite_{name}"
    folder.mkdir()
    target = folder / "out"
    _simulation(cls, target, registry, params=params).run()
    before = fingerprint(target)
    try:
        _simulation(cls, target, registry, params=params)
    except DataError:
        pass
    else:
        raise AssertionError(f"writer '{name}': an existing output was accepted without "
                             "overwrite")
    assert fingerprint(target) == before, f"writer '{name}': a refused run changed the file"
    short = STEPS // 2
    _simulation(cls, target, registry, steps=short, overwrite=True, params=params).run()
    _check_steps(name, target, _expected(short), steps, "an output replaced (overwrite)")
    foreign = folder / "foreign"
    foreign.write_bytes(b"not written by siku\n")
    try:
        _simulation(cls, foreign, registry, overwrite=True, params=params)
    except DataError:
        pass
    else:
        raise AssertionError(f"writer '{name}': overwrite was allowed to replace a file the "
                             "writer did not write")
    assert foreign.read_bytes() == b"not written by siku\n"


def check_writer_restart(name: str, tmp_path: Path, registry: Registry | None = None,
                         params: dict | None = None, steps: Steps = snapshot_steps) -> None:
    cls = _writer_class(name, registry)
    folder = Path(tmp_path) / f"restart_{name}"
    folder.mkdir()
    whole = _simulation(cls, folder / "whole", registry, params=params).run()
    _check_steps(name, folder / "whole", _expected(), steps, "an uninterrupted run")
    half = STEPS // 2 - (STEPS // 2) % EVERY or EVERY
    part = folder / "part"
    stopped = _simulation(cls, part, registry, params=params)
    stopped.run(steps=half)
    try:
        snap = cls.read_restart(part, stopped.context)
    except DataError as exc:
        assert "\n" not in str(exc) and str(part) in str(exc), (
            f"writer '{name}': read_restart refuses in more than one line, or without naming "
            f"the file: {exc}")
        return
    assert int(snap["step"]) == half, (
        f"writer '{name}': read_restart gives step {snap['step']}, the last snapshot is {half}")
    for k in ("q", "V", "w"):
        assert np.array_equal(np.asarray(snap[k]), getattr(stopped.state, k)), (
            f"writer '{name}': read_restart's {k} differs from the state it wrote")
    out = part if cls.appends else folder / "continued"
    again = _simulation(cls, out, registry, restart=part, params=params)
    assert again.step_index == half, f"writer '{name}': the restart began at {again.step_index}"
    again.run()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(again.state, k), getattr(whole.state, k)), (
            f"writer '{name}': the continued run's {k} differs from the run that never stopped")
    _check_steps(name, out, _expected(start=0 if cls.appends else half), steps,
                 f"a run restarted at step {half}" + (" in its own file" if cls.appends else ""))
    assert _leftovers(folder, {"whole", "part", out.name}) == [], (
        f"writer '{name}': a restart left {_leftovers(folder, {'whole', 'part', out.name})}")


def check_writer(name: str, tmp_path: Path | None = None, registry: Registry | None = None,
                 params: dict | None = None, steps: Steps = snapshot_steps) -> None:
    """Every check of the suite for the writer registered as ``name`` (``params``: its
    parameters; ``steps``: the reader of a file's snapshot steps); files go under
    ``tmp_path`` (default: a temporary folder, removed after)."""
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp_path) if tmp_path is not None else Path(tmp)
        check_writer_publish(name, where, registry, params, steps)
        check_writer_owns(name, where, registry, params)
        check_writer_overwrite(name, where, registry, params, steps)
        check_writer_restart(name, where, registry, params, steps)


def shipped_writers(registry: Registry | None = None) -> list[str]:
    """The names of every registered writer of files (for ``pytest.mark.parametrize``): a
    writer whose class says ``in_memory = True`` writes no file and is not checked here."""
    entries = (registry or get_registry()).entries.get("writer", {})
    return sorted(n for n, e in entries.items() if not e.cls.in_memory)


__all__ = ["STEPS", "DT", "EVERY", "StopBeforeFirstSnapshot", "check_writer",
           "check_writer_owns", "check_writer_overwrite", "check_writer_publish",
           "check_writer_restart", "fingerprint", "shipped_writers", "snapshot_steps",
           "writer_scene_text"]
