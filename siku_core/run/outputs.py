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

The engine checks the output path (:func:`check_output_path`) before any component does work;
every other path siku writes (grid and export files, summaries, pictures, mesh caches) passes
the same rule, :func:`check_target`: a path naming an existing file that siku did not write
(identified by the marks siku writes inside its files, never by the name) is never replaced,
truncated or written to, whatever ``--overwrite`` says; nothing is written to a device, a FIFO
or a folder given as a file.
"""
from __future__ import annotations

import contextlib
import contextvars
import errno
import fcntl
import os
import shlex
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

from ..errors import DataError, SceneError

@dataclass(frozen=True)
class Options:
    """How a refusal names the caller's settings: the command line's flags (``siku run
    --overwrite``) or the Python API's arguments (``Simulation(overwrite=True)``), so that the
    advice of one shared rule is something the caller can do."""

    out: str
    overwrite: str
    restart: str
    force: str
    #: the setting that lengthens a finished run, written before its value
    extend: str
    #: what its value is, and an example (6 hours)
    duration: str
    duration_example: str

    def restart_with(self, path: Path | str) -> str:
        """The setting that continues the output file ``path``."""
        if self.restart.startswith("--"):
            return f"{self.restart} {shlex.quote(str(path))}"
        return f"{self.restart}{str(path)!r}"


#: the command line's wording (``siku run``)
COMMAND_LINE = Options(out="--out", overwrite="--overwrite", restart="--restart",
                       force="--force", extend="--extend ", duration="DURATION",
                       duration_example="6h")
#: the Python API's wording (``Simulation``, ``SceneBuilder``), the default
PYTHON_API = Options(out="out=", overwrite="overwrite=True", restart="restart=",
                     force="force=True", extend="extend=", duration="SECONDS",
                     duration_example="21600")
_OPTIONS: contextvars.ContextVar[Options] = contextvars.ContextVar("siku_options",
                                                                   default=PYTHON_API)


def options() -> Options:
    """The wording of the caller's settings: :data:`PYTHON_API` unless the caller is the
    command line (:func:`command_line`)."""
    return _OPTIONS.get()


@contextlib.contextmanager
def command_line():
    """Within this block refusals name the command line's flags (:data:`COMMAND_LINE`)."""
    token = _OPTIONS.set(COMMAND_LINE)
    try:
        yield
    finally:
        _OPTIONS.reset(token)


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

    walk(scene.cfg.model_dump(exclude={"output": {"file": True, "extra": {"__all__": {"file"}}}}),
         "")
    found.extend(extra)
    return found


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_target(path: str | Path, *, what: str = "output file",
                 ours: Callable[[Path], bool] | None = None, overwrite: bool = False,
                 inputs: Iterable[tuple[str, Path]] = (), appending_to: Path | None = None,
                 option: str | None = None, overwrite_option: str | None = None,
                 follow_links: bool = True, continue_option: str = "",
                 folder: bool = False) -> Path:
    """May siku write ``path``? The one rule for every file siku writes; refused with a
    one-line :class:`DataError` naming the file and what to do:

    * a name with a NUL character, a folder, a device, a FIFO or a socket: never written;
    * one of the run's ``inputs`` (``(key, path)``): never written;
    * an existing file: only with ``overwrite`` (or when the run continues it:
      ``appending_to``), and only when ``ours(path)`` identifies it, by reading the marks siku
      writes inside its files, as siku's own ``what`` (without ``ours`` nothing is replaced);
    * a file another process holds (:func:`in_use`).

    ``option`` names the setting that chose the path in the messages, ``overwrite_option``
    the one that allows replacing (both by default as the caller names them, :func:`options`:
    ``--out`` and ``--overwrite`` on the command line, ``out=`` and ``overwrite=True`` in
    Python); with
    ``overwrite_option=""``: the command replaces its own files without being asked (no
    option to name); ``continue_option`` (e.g. ``--restart``) is advised for an existing file
    of siku's own; with
    ``follow_links=False`` a symbolic link is not followed: it counts as the existing file
    itself (replaced only with ``overwrite``, its target never written). With ``folder=True``
    the file is a folder (a Zarr store): an existing folder is the existing file, under the
    same rules."""
    path = Path(path)
    said = options()
    option = said.out if option is None else option
    overwrite_option = said.overwrite if overwrite_option is None else overwrite_option
    if "\x00" in str(path):
        raise DataError(f"{str(path)!r}: a file name cannot hold a NUL character")
    if not follow_links and path.is_symlink():
        if not overwrite:
            raise DataError(f"{path}: exists (a symbolic link); choose another {option}, or "
                            f"pass {overwrite_option} to replace the link (never its target)")
        return path
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None
    except OSError as exc:  # a file used as a folder, a name too long, a loop of links
        raise DataError(f"{path}: cannot be written ({exc.strerror}); choose another "
                        f"{option}") from None
    if st is not None and stat.S_ISDIR(st.st_mode) and not folder:
        raise DataError(f"{path}: is a folder; {option} names the {what}")
    if st is not None and not (stat.S_ISREG(st.st_mode) or folder and stat.S_ISDIR(st.st_mode)):
        raise DataError(f"{path}: is not a regular file (a device, FIFO or socket); siku "
                        f"writes its {what} only to a regular file: choose another {option}")
    for key, p in inputs:
        if _same(path, p):
            raise DataError(f"{path}: the {what} would overwrite an input of this run "
                            f"({key}: {p}); choose another {option}")
    if st is None:
        return path
    if appending_to is not None and _same(path, appending_to):
        pass
    elif not overwrite:
        again = ""
        if continue_option and ours is not None and ours(path):
            again = f"; it is {_a(what)} siku wrote: continue it with {continue_option}"
        raise DataError(f"{path}: exists; choose another {option}, or pass "
                        f"{overwrite_option} to replace it (the old file stays whole until the "
                        f"new one is complete){again}")
    elif ours is None or not ours(path):
        only = (f"{overwrite_option} replaces only its own {what}s" if overwrite_option else
                f"it replaces only its own {what}s")
        raise DataError(f"{path}: exists and is not {_a(what)} siku wrote; siku never replaces "
                        f"a file it did not write ({only}): move it away or choose another "
                        f"{option}")
    if in_use(path):
        raise DataError(f"{path}: is being written by another run (or held open by another "
                        f"program); wait for it to finish or choose another {option}")
    return path


def _a(noun: str) -> str:
    return f"{'an' if noun[:1] in 'aeiou' else 'a'} {noun}"


def check_output_path(path: Path, inputs: list[tuple[str, Path]], *, overwrite: bool,
                      appending_to: Path | None = None,
                      ours: Callable[[Path], bool] | None = None,
                      folder: bool = False) -> None:
    """The run's output path under :func:`check_target`: ``ours`` is the writer's
    :meth:`~siku_core.interfaces.Writer.owns`; an existing output of the writer is refused
    with the advice to continue it (``--restart PATH`` on the command line, ``restart=PATH``
    in Python: :func:`options`); ``folder``: the writer's output is a folder
    (:attr:`~siku_core.interfaces.Writer.folder`)."""
    check_target(path, what="output file", ours=ours, overwrite=overwrite, inputs=inputs,
                 appending_to=appending_to, continue_option=options().restart_with(path),
                 folder=folder)


def partial_path(target: Path) -> Path:
    """Where a writer builds ``target`` before :func:`publish` (same folder, so the final
    rename is atomic): ``.NAME.PID.partial``."""
    return target.with_name(f".{target.name}.{os.getpid()}.partial")


def publish(partial: Path, target: Path, *, replace: bool) -> None:
    """Put the file ``partial`` in place as ``target`` atomically.

    ``replace=False`` never replaces a file that appeared at ``target`` meanwhile (a hard link
    fails if the name exists); ``replace=True`` replaces it in one rename. A folder (a Zarr
    store) replaces a folder by exchanging the two names in one call (:func:`exchange`), then
    removes the old one: at every moment ``target`` names a whole store.
    """
    if partial.is_dir() and not partial.is_symlink():
        return _publish_folder(partial, target, replace)
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


def _publish_folder(partial: Path, target: Path, replace: bool) -> None:
    """:func:`publish` of a folder."""
    import shutil

    if not os.path.lexists(target):
        try:
            os.mkdir(target)  # claims the name: fails if it appeared meanwhile
        except FileExistsError:
            if not replace:
                raise DataError(f"{target}: was created by another process while this run "
                                f"started; this run's output is in {partial}") from None
    elif not replace:
        raise DataError(f"{target}: was created by another process while this run started; "
                        f"this run's output is in {partial}")
    if os.path.isdir(target) and not os.path.islink(target):
        exchange(partial, target)  # the new store at target, the old one at partial
        shutil.rmtree(partial, ignore_errors=True)
    else:  # a link or a file siku wrote in its place: replaced in one rename
        os.replace(partial, target)


def exchange(a: Path, b: Path) -> None:
    """Exchange the names ``a`` and ``b`` (two folders) in one call, ``renameat2`` with
    ``RENAME_EXCHANGE`` (Linux 3.15): neither name is ever missing. Where the call is missing,
    ``b`` goes aside, ``a`` takes its name and the old ``b`` takes ``a``'s (a fault in between
    leaves both folders whole, the old one at ``a``)."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        renameat2 = None
    if renameat2 is not None:
        at_fdcwd, rename_exchange = -100, 2
        if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
            return
    aside = b.with_name(f"{b.name}.{os.getpid()}.old")
    os.rename(b, aside)
    os.rename(a, b)
    os.rename(aside, a)


def write_text_file(path: Path, text: str, *, replace: bool) -> None:
    """Write ``text`` (UTF-8) as ``path`` checked by :func:`check_target`: built beside it
    (:func:`partial_path`) and put in place by :func:`publish`, so a link at ``path`` is
    replaced, never followed, and a file that appeared meanwhile is not replaced unless
    ``replace``."""
    partial = partial_path(Path(path))
    try:
        partial.write_text(text, encoding="utf-8")
    except BaseException as exc:
        with contextlib.suppress(OSError):  # (a read-only file system: nothing to remove)
            partial.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise DataError(f"{path}: cannot be written ({exc.strerror or exc}); nothing "
                            "written: choose a folder siku may write") from None
        raise
    publish(partial, Path(path), replace=replace)


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
    """Whether a process holds ``path`` (a file, or a folder such as a Zarr store) open with a
    lock (a running siku run, or an HDF5 program): an exclusive ``flock`` cannot be taken."""
    try:
        mode = os.stat(path).st_mode
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            return False
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
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
    if not writer.published:
        writer._discard()  # stopped before its first new snapshot: an old file stays
    elif writer.target is not None:
        fsync_path(writer.target)
    if writer.lock is not None:
        writer.lock.release()
        writer.lock = None


def restart_differences(stored: dict, current: dict, ignore: Iterable[str] = ()) -> list[str]:
    """``"key: stored -> current"`` for every flattened key that differs between two run
    records (:meth:`~siku_core.run.simulation.Simulation.run_record`), skipping keys that start with
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


def extra_output_paths(scene: Any, primary: Path | None, overwrite: bool, restart: bool,
                       writer_class: Any) -> list[Path]:
    """The files of the scene's ``[[output.extra]]`` writers, each checked like the primary
    output (none when the run writes nothing): two writers never share a file. On a restart
    a writer that continues its own file (``writer_class(name, where).appends``) may find it
    there; any other's existing file is refused like any output."""
    if primary is None:
        return []
    paths: list[Path] = []
    seen = {primary.resolve()}
    for k, x in enumerate(scene.cfg.output.extra):
        p = Path(x.file)
        if p.resolve() in seen:
            raise SceneError(f"{scene.where(f'output.extra[{k}]')}: file '{x.file}' is "
                             "already written by another writer of this run; give each writer "
                             "its own file")
        seen.add(p.resolve())
        where = f"{scene.where(f'output.extra[{k}]')}: "
        cls = writer_class(x.writer, where)
        cont = restart and cls.appends
        if restart and not cont and p.exists() and not overwrite:
            raise DataError(f"{where}{p} exists and the '{x.writer}' writer cannot continue a "
                            "file: give it a new file for the continuation (its file = "
                            "'...'); the old file keeps the rows before the restart")
        check_output_path(p, input_paths(scene), overwrite=overwrite,
                          appending_to=p if cont else None, ours=cls.owns,
                          folder=cls.folder)
        paths.append(p)
    return paths


__all__ = ["check_output_path", "check_target", "Options", "COMMAND_LINE", "PYTHON_API",
           "options", "command_line", "extra_output_paths", "input_paths",
           "partial_path", "publish", "exchange", "RunLock", "in_use",
           "is_disk_full", "restart_differences", "fsync_path", "settle", "DISK_FULL"]
