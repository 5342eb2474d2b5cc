"""Which files siku wrote, told by the marks siku writes inside them, and writing a file so
that a full disk leaves nothing half-written (``docs/explanation/outputs.md``).

Every test here only reads: a file is opened read-only (HDF5 and NetCDF files through their
libraries, pictures through Pillow, meshes as ``.npz``) and never changed, whatever it is. The
marks, by kind of file:

* ``output`` (the HDF5 writer): root attributes ``siku_version`` and ``layout`` and the group
  ``/states``;
* ``netcdf output`` (the NetCDF writer): global attributes ``siku_siku_version`` and
  ``siku_scene``, an unlimited ``time`` dimension and the variable ``step``;
* ``export`` (``siku export``): global attribute ``siku_siku_version`` and the dimension
  ``obs``;
* ``zarr output`` (the Zarr writer, a folder): a Zarr group whose root ``zarr.json`` has the
  attributes ``siku_version`` and ``layout`` and the group ``states``;
* ``zarr export`` (``siku export --to zarr``, a folder): a Zarr group with the attribute
  ``siku_siku_version`` and the array ``obs`` dimension of the trajectory layout;
* ``grid`` (``siku grid``, ``[output.grid]``): global attributes ``grid`` and a ``source``
  ending ``(siku grid)``;
* ``summary`` (an ensemble's): global attribute ``kind = "siku ensemble summary"``;
* ``picture`` (PNG, PDF and SVG maps, GIF animations): the PNG text ``Software``, the GIF
  comment, the PDF ``Creator`` or the SVG title starting ``siku``;
* ``mesh`` (a mesh cache): the array ``format = "siku-mesh"``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from siku_core.errors import DataError
from siku_core.run.outputs import check_target, fsync_path, is_disk_full, partial_path, publish

_HDF5 = b"\x89HDF\r\n\x1a\n"
_NETCDF = (b"CDF\x01", b"CDF\x02", b"CDF\x05")
PICTURE_MARK = "siku"


def _head(path: Path, n: int = 8) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read(n)
    except OSError:
        return b""


def is_hdf5_output(path: str | Path) -> bool:
    """An HDF5 output file of siku's HDF5 writer (also one a killed run left marked "open for
    writing", read in SWMR mode). Read in a child process (:func:`in_child`), so that a
    damaged file that crashes the HDF5 library is not identified and this process goes on."""
    path = Path(path)
    if not path.is_file() or _head(path) != _HDF5:
        return False
    import h5py  # noqa: F401 - imported once here, not in every child

    return _once(path, "hdf5", lambda: "yes" if _is_hdf5_output(path) else None) == "yes"


def _is_hdf5_output(path: Path) -> bool:
    import h5py

    def ours(f) -> bool:
        if not ("siku_version" in f.attrs and "layout" in f.attrs and "states" in f):
            return False
        _read_every_attribute(f)
        return True

    try:
        with h5py.File(path, "r") as f:
            return ours(f)
    except Exception as exc:  # noqa: BLE001 - anything unreadable is not identified
        if "already open for write" not in str(exc):
            return False
    # marked "open for writing" (a killed writer, or a run writing it now): read through a
    # view of the file with the mark cleared, never SWMR's retries on a damaged file
    from .open_mark import MarkedReader

    try:
        reader = MarkedReader(path)
    except OSError:
        return False
    try:
        with h5py.File(reader, "r", driver="fileobj") as f:
            return ours(f)
    except Exception:  # noqa: BLE001
        from siku_core.run.outputs import in_use

        if not in_use(path):
            return False
    finally:
        reader.close()
    try:  # a file a run is writing now: SWMR reads it as it is
        with h5py.File(path, "r", swmr=True) as f:
            return ours(f)
    except Exception:  # noqa: BLE001
        return False


def _zarr_root(path: Path) -> dict | None:
    """The root metadata (``zarr.json``) of a Zarr version 3 group at the folder ``path``, or
    ``None``. Plain JSON, read here (no library that can crash on a damaged file)."""
    import json

    try:
        if not path.is_dir():
            return None
        meta = json.loads((path / "zarr.json").read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(meta, dict) or meta.get("node_type") != "group":
        return None
    return meta


def zarr_kind(path: str | Path) -> str | None:
    """``"zarr output"`` (the Zarr writer's store) or ``"zarr export"`` (``siku export --to
    zarr``) for a folder siku wrote, else ``None``."""
    meta = _zarr_root(Path(path))
    if meta is None:
        return None
    attrs = meta.get("attributes") or {}
    if "siku_version" in attrs and "layout" in attrs and (Path(path) / "states").is_dir():
        return "zarr output"
    if "siku_siku_version" in attrs and attrs.get("featureType") == "trajectory":
        return "zarr export"
    return None


def is_zarr_output(path: str | Path) -> bool:
    """A store of siku's Zarr writer (module docstring)."""
    return zarr_kind(path) == "zarr output"


def in_child(fn: Callable[[], str | None], timeout: float = 10.0) -> str | None:
    """``fn()`` run in a forked child process, its answer (a short string or ``None``) sent
    back through a pipe. The NetCDF and HDF5 C libraries can crash the whole process (a
    segmentation fault) or loop for ever on some damaged files; a child that crashes, fails or
    outlives ``timeout`` [s] (reading a file's marks takes milliseconds) answers ``None`` (not
    identified), and the command that asked goes on to refuse the file in one line. Where
    ``fork`` is missing, ``fn`` runs here."""
    import os
    import time

    if not hasattr(os, "fork"):  # pragma: no cover - not POSIX
        return fn()
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: answer, then leave without running any exit handler
        code = 1
        try:
            os.close(r)
            import faulthandler

            faulthandler.disable()  # a crash here is an answer, not a report on the terminal
            os.dup2(os.open(os.devnull, os.O_WRONLY), 2)
            os.write(w, ("\x00" + (fn() or "")).encode())
            code = 0
        finally:
            os._exit(code)
    os.close(w)
    status = None
    try:  # whatever ends the wait (its time limit, Ctrl-C, an alarm), no child outlives it
        deadline = time.monotonic() + timeout
        while status is None and time.monotonic() <= deadline:
            done, st = os.waitpid(pid, os.WNOHANG)
            if done:
                status = st
            else:
                time.sleep(0.002)
        answer = os.read(r, 1 << 16).decode() if status is not None else ""
    finally:
        os.close(r)
        if status is None:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
    if status is None or not (os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0) \
            or not answer:
        return None
    return answer[1:] or None


def netcdf_kind(path: str | Path) -> str | None:
    """``"netcdf output"``, ``"export"``, ``"grid"``, ``"summary"`` or ``"fsd"`` (a floe size
    distribution of ``siku fsd``) for a NetCDF file siku wrote, else ``None``. The file is
    read in a child process (:func:`in_child`): a damaged
    file that crashes the NetCDF library is not identified, and this process goes on."""
    path = Path(path)
    head = _head(path)
    if not path.is_file() or not (head == _HDF5 or head[:4] in _NETCDF):
        return None
    import netCDF4  # noqa: F401 - imported once here, not in every child

    return _once(path, "netcdf", lambda: _netcdf_kind(path))


#: answers of :func:`in_child` by file identity: a file is identified once per process while it
#: stays the same (inode, size, modification time), so a damaged file that hangs the library
#: costs one time limit, not one per reader that asks
_ANSWERS: dict[tuple, str | None] = {}


def _once(path: Path, what: str, fn: Callable[[], str | None]) -> str | None:
    try:
        st = path.stat()
    except OSError:
        return None
    key = (what, str(path.resolve()), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _ANSWERS:
        _ANSWERS[key] = in_child(fn)
    return _ANSWERS[key]


def _read_every_attribute(f) -> None:
    """Read every attribute of every group and dataset of an open HDF5 file (``h5py``), in the
    child of :func:`in_child`: the HDF5 library can loop for ever or crash on a damaged
    attribute deep in a file whose marks read well (the slow reader fuzz found one in the
    ``/geometry`` datasets), and the readers would then hang in this process. An error is left
    to the readers, which report it in one line."""
    def attrs(obj) -> None:
        try:
            for key in obj.attrs:
                obj.attrs.get(key)
        except Exception:  # noqa: BLE001 - reported by the reader, in one line
            pass

    attrs(f)
    try:
        f.visititems(lambda name, obj: attrs(obj))
    except Exception:  # noqa: BLE001
        pass


def _netcdf_kind(path: Path) -> str | None:
    try:
        import netCDF4

        with netCDF4.Dataset(path, "r") as nc:
            for v in nc.variables.values():  # as _read_every_attribute, for NetCDF
                try:
                    for key in v.ncattrs():
                        v.getncattr(key)
                except Exception:  # noqa: BLE001 - reported by the reader, in one line
                    pass
            a = set(nc.ncattrs())
            if "kind" in a and nc.getncattr("kind") == "siku ensemble summary":
                return "summary"
            if ("kind" in a and nc.getncattr("kind") == "siku floe size distribution"
                    and "area_bin" in nc.dimensions):
                return "fsd"
            if "grid" in a and str(nc.getncattr("source") if "source" in a else ""
                                   ).endswith("(siku grid)"):
                return "grid"
            if "siku_siku_version" in a:
                if "obs" in nc.dimensions:
                    return "export"
                if ("time" in nc.dimensions and nc.dimensions["time"].isunlimited()
                        and "step" in nc.variables and "siku_scene" in a):
                    return "netcdf output"
    except Exception:  # noqa: BLE001 - anything unreadable is not identified
        return None
    return None


def is_picture(path: str | Path) -> bool:
    """A PNG map or GIF animation siku drew (its ``Software`` text or GIF comment), or a PDF or
    SVG map (its ``Creator``)."""
    path = Path(path)
    if not path.is_file():
        return False
    if path.suffix.lower() in (".pdf", ".svg"):  # the PDF Info's Creator, the SVG's metadata
        try:
            with path.open("rb") as f:
                head = f.read(4096)
                f.seek(max(0, path.stat().st_size - 8192))
                tail = f.read()
        except OSError:
            return False
        mark = PICTURE_MARK.encode()
        return (head.startswith(b"%PDF") and b"/Creator (" + mark in tail) or (
            b"<svg" in head and b">" + mark + b" " in head)
    try:
        from PIL import Image

        with Image.open(path) as im:
            mark = im.info.get("Software", im.info.get("comment", b""))
    except Exception:  # noqa: BLE001
        return False
    if isinstance(mark, bytes):
        mark = mark.decode("latin-1")
    return str(mark).startswith(PICTURE_MARK)


def is_mesh_cache(path: str | Path) -> bool:
    """A mesh cache siku wrote (``siku_io.mesh.mesh_file``), of any format version."""
    path = Path(path)
    if not path.is_file() or _head(path, 4) != b"PK\x03\x04":
        return False
    try:
        import numpy as np

        from siku_io.mesh.mesh_file import FORMAT

        with np.load(path, allow_pickle=False) as z:
            return "format" in z.files and str(z["format"]) == FORMAT
    except Exception:  # noqa: BLE001
        return False


def kind_test(kind: str) -> Callable[[Path], bool]:
    """The test that a file is siku's of ``kind`` (module docstring)."""
    if kind == "output":
        return is_hdf5_output
    if kind == "picture":
        return is_picture
    if kind == "mesh":
        return is_mesh_cache
    if kind.startswith("zarr"):
        return lambda p: zarr_kind(p) == kind
    return lambda p: netcdf_kind(p) == kind


def writable(path: str | Path, kind: str, *, overwrite: bool, what: str | None = None,
             option: str = "--out", inputs=(), overwrite_option: str = "--overwrite") -> Path:
    """:func:`siku_core.run.outputs.check_target` for a file of ``kind`` (a Zarr kind is a
    folder)."""
    return check_target(path, what=what or f"{kind} file", ours=kind_test(kind),
                        overwrite=overwrite, option=option, inputs=inputs,
                        overwrite_option=overwrite_option, folder=kind.startswith("zarr"))


def _discard(part: Path) -> None:
    """Remove a partial file if there is one; on a read-only file system there is none to
    remove (and removing raises), so nothing is done."""
    try:
        part.unlink(missing_ok=True)
    except OSError:
        pass


def write_whole(target: str | Path, write: Callable[[Path], object], what: str,
                replace: bool = True) -> Path:
    """Write ``target`` through ``write(partial)``: built beside it, put in place in one
    rename when complete. A failure (a full disk first of all) removes the partial file,
    leaves an old ``target`` whole and raises a one-line :class:`DataError`."""
    target = Path(target)
    part = partial_path(target)
    try:
        write(part)
        publish(part, target, replace=replace)
    except DataError:
        _discard(part)
        raise
    except Exception as exc:  # noqa: BLE001 - every library's error of a failed write
        _discard(part)
        why = "disk full" if is_disk_full(exc) or _disk_full_now(target) else (
            f"cannot write: {' '.join(str(exc).split())[:300]}")
        raise DataError(f"{target}: {why} while writing the {what}; nothing written (an "
                        "existing file is untouched)") from None
    fsync_path(target)
    return target


def _disk_full_now(target: Path) -> bool:
    """Whether the disk (or the file-size limit) has no room left: libraries that report a
    failed write without its errno (NetCDF's "HDF error") leave this the only test."""
    import resource
    import shutil

    try:
        free = shutil.disk_usage(target.parent).free
    except OSError:
        return False
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    return free < 1 << 20 or (limit != resource.RLIM_INFINITY and limit < 1 << 40)


__all__ = ["is_hdf5_output", "is_zarr_output", "zarr_kind", "netcdf_kind", "in_child",
           "is_picture", "is_mesh_cache", "kind_test", "writable", "write_whole", "PICTURE_MARK"]
