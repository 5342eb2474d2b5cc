"""Output files that are never lost: the rules every writer follows, and their tools.

The rules (``docs/explanation/outputs.md``):

* A run never truncates or replaces an existing file unless told to (``--overwrite``, or a
  restart that continues the same file); the output path may not be one of the run's inputs
  (scene, forcing, mesh or any other file the scene names).
* A writer builds its file under a temporary name beside the target (:func:`partial_path`) and
  puts it in place (:func:`publish`) only once it holds its first snapshot: an old file given
  to ``--overwrite`` stays whole until the new one has real data, and a run that stops before
  its first snapshot leaves nothing behind.
* While a run writes a file it holds a shared lock on it (:class:`RunLock`); another run that
  wants to replace the file, and siku's readers deciding whether the file is still being
  written, ask :func:`in_use`.

The engine checks the output path (:func:`check_output_path`) before any component does work.
"""
from __future__ import annotations

import errno
import fcntl
import os
from pathlib import Path
from typing import Any, Iterable

from .errors import DataError

#: errno values that mean "the disk (or the quota, or the file-size limit) is full"
DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` (an ``OSError``, or an h5py error whose text names the errno) reports a
    full disk, quota or file-size limit."""
    if isinstance(exc, OSError) and exc.errno in DISK_FULL:
        return True
    text = str(exc)
    return any(f"errno = {e}," in text or os.strerror(e) in text for e in DISK_FULL)


def input_paths(scene: Any, extra: Iterable[tuple[str, Path]] = ()) -> list[tuple[str, Path]]:
    """``(key, path)`` of every existing file the run reads: the scene file and every string
    value of the scene (any table, any component parameter) that names an existing file,
    resolved against the scene's folder."""
    found: list[tuple[str, Path]] = []
    if scene.path is not None:
        found.append(("scene file", Path(scene.path)))

    def walk(value: Any, key: str) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, f"{key}.{k}" if key else str(k))
        elif isinstance(value, (list, tuple)):
            for i, v in enumerate(value):
                walk(v, f"{key}[{i}]")
        elif isinstance(value, str) and value.strip() and len(value) < 4096:
            p = Path(value).expanduser()
            p = p if p.is_absolute() else scene.base_dir / p
            try:
                if p.is_file():
                    found.append((f"[{key}]", p))
            except (OSError, ValueError):  # too long, a NUL byte...: not a file name
                pass

    walk(scene.cfg.model_dump(exclude={"output": {"file"}}), "")
    found.extend(extra)
    return found


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_output_path(path: Path, inputs: list[tuple[str, Path]], *, overwrite: bool,
                      appending_to: Path | None = None) -> None:
    """Refuse an output path that would lose data (one-line :class:`DataError`):

    * a folder, or one of the run's ``inputs`` (``(key, path)``);
    * an existing file, unless ``overwrite`` or the run continues that file
      (``appending_to``, the restart file);
    * a file another process is writing (:func:`in_use`).
    """
    if "\x00" in str(path):
        raise DataError(f"{str(path)!r}: an output file name cannot hold a NUL character")
    if path.is_dir():
        raise DataError(f"{path}: is a folder; --out (or [output] file) names the output file")
    for key, p in inputs:
        if _same(path, p):
            raise DataError(f"{path}: the output file would overwrite an input of this run "
                            f"({key}: {p}); choose another --out")
    if not path.exists():
        return
    if appending_to is not None and _same(path, appending_to):
        pass
    elif not overwrite:
        raise DataError(f"{path}: exists; choose another --out, or pass --overwrite to replace "
                        "it (the old file stays whole until the new one holds a snapshot)")
    if in_use(path):
        raise DataError(f"{path}: is being written by another run (or held open by another "
                        "program); wait for it to finish or choose another --out")


def partial_path(target: Path) -> Path:
    """Where a writer builds ``target`` before :func:`publish` (same folder, so the final
    rename is atomic): ``.NAME.PID.partial``."""
    return target.with_name(f".{target.name}.{os.getpid()}.partial")


def publish(partial: Path, target: Path, *, replace: bool) -> None:
    """Put the file ``partial`` in place as ``target`` atomically.

    ``replace=False`` never replaces a file that appeared at ``target`` meanwhile (a hard link
    fails if the name exists); ``replace=True`` replaces it in one rename.
    """
    if replace:
        os.replace(partial, target)
        return
    try:
        os.link(partial, target)
    except FileExistsError:
        raise DataError(f"{target}: was created by another process while this run started; "
                        f"this run's output is in {partial}") from None
    except OSError:  # a file system without hard links: rename (never over an existing name)
        if target.exists():
            raise DataError(f"{target}: was created by another process while this run started; "
                            f"this run's output is in {partial}") from None
        os.rename(partial, target)
        return
    os.unlink(partial)


def fsync_path(path: Path) -> None:
    """Ask the operating system to write ``path`` and its folder entry to the disk."""
    for p, flags in ((path, os.O_RDONLY), (path.parent, os.O_RDONLY)):
        try:
            fd = os.open(p, flags)
        except OSError:
            continue
        try:
            os.fsync(fd)
        except OSError:
            pass
        finally:
            os.close(fd)


class RunLock:
    """A shared ``flock`` held on an output file while a run writes it (released by the
    operating system when the process ends, however it ends)."""

    def __init__(self, path: Path):
        self.fd = os.open(path, os.O_RDONLY)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            raise DataError(f"{path}: is being written by another run") from None

    def release(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def in_use(path: Path) -> bool:
    """Whether a process holds ``path`` open with a lock (a running siku run, or an HDF5
    program): an exclusive ``flock`` cannot be taken."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


def settle(writer: Any) -> None:
    """A writer's file after the writer closed it: a file never put in place (the run stopped
    before its first snapshot) is removed (``writer._discard()``), a published one is synced to
    the disk, and the run's lock on it is released."""
    if not getattr(writer, "published", True):
        writer._discard()  # stopped before its first new snapshot: an old file stays
    elif hasattr(writer, "target"):
        fsync_path(writer.target)
    if getattr(writer, "lock", None) is not None:
        writer.lock.release()
        writer.lock = None


def restart_differences(stored: dict, current: dict, ignore: Iterable[str] = ()) -> list[str]:
    """``"key: stored -> current"`` for every flattened key that differs between two run
    records (:meth:`~siku_core.simulation.Simulation.run_record`), skipping keys that start with
    an entry of ``ignore``."""
    def flat(d: Any, key: str = "") -> dict[str, Any]:
        if isinstance(d, dict):
            out: dict[str, Any] = {}
            for k, v in d.items():
                out.update(flat(v, f"{key}.{k}" if key else str(k)))
            return out
        if isinstance(d, list) and any(isinstance(v, (dict, list)) for v in d):
            out = {}
            for i, v in enumerate(d):
                out.update(flat(v, f"{key}[{i}]"))
            return out
        return {key: d}

    a, b = flat(stored), flat(current)
    skip = tuple(ignore)
    diffs = []
    for k in sorted(set(a) | set(b)):
        if skip and k.startswith(skip):
            continue
        if a.get(k, "(absent)") != b.get(k, "(absent)"):
            diffs.append(f"{k}: {a.get(k, '(absent)')!r} -> {b.get(k, '(absent)')!r}")
    return diffs


__all__ = ["check_output_path", "input_paths", "partial_path", "publish", "RunLock", "in_use",
           "is_disk_full", "restart_differences", "fsync_path", "settle", "DISK_FULL"]
