"""Zarr output (a folder, Zarr format 3): the writer ``[output] writer = "zarr"``, restartable
as the HDF5 output, and ``siku export --to zarr``.

The writer's store holds the HDF5 output's layout (``siku_io.output.hdf5``), group for group
and array for array, with the same values, ``units`` and ``long_name`` (``grid``, CF flag
meanings, ``standard_name`` where declared), and the same root attributes; the texts the HDF5
file keeps as datasets (``scene``, ``run_record``, ``components``) are root attributes.
Every array names its dimensions (``time``, ``element``, ``node``, ``break``...), so
``xr.open_zarr(store, group="states")`` (or ``"geometry"``, ``"diagnostics"``, ``"breaks"``)
reads a group as it is, and ``xr.open_dataset(store, engine="siku")`` gives the dataset the
HDF5 file gives.

How nothing is lost (``docs/explanation/outputs.md``), as the HDF5 writer:

* the store is built beside the target (``.NAME.PID.partial``) and put in place once it holds
  its first snapshot; an existing store is replaced only when the engine allows it
  (``--overwrite`` of a store this writer made, or a restart continuing it, which copies the
  complete snapshots), by exchanging the two folders' names in one call
  (:func:`siku_core.run.outputs.publish`);
* every file of the store is written under a temporary name and renamed into place (Zarr's
  local store), and a snapshot is committed by writing the root ``zarr.json`` with the
  consolidated metadata of every array last: **the complete snapshots are those the root
  metadata counts** (the length of ``states/step`` there). Rows a killed run wrote after it
  are in no array's shape a reader sees through it (``xr.open_zarr``, ``zarr.open_consolidated``
  and every siku reader), and a restart copies only the counted ones.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import warnings
from pathlib import Path

import numpy as np

from siku_core import PLUGIN_API_VERSION, DataError, Param, __version__, hookimpl
from siku_core.run.outputs import RunLock, is_disk_full, partial_path

from .hdf5 import HDF5Writer
from .layout import GEOMETRY, dataset_attrs
from .padded import is_padded, pad_value
from .results import LAYOUT

#: dimension names of the fixed-shape arrays, by path
_DIMS = {
    "states/q": ("time", "element", "quaternion"),
    "states/V": ("time", "element", "local_axis"),
    "geometry/vert_offsets": ("element_bound",),
    "geometry/verts": ("node", "local_axis"),
}


def dimension_names(path: str, ndim: int) -> tuple[str, ...]:
    """The dimensions of the array at ``path`` (``ndim`` axes) in a store of the writer."""
    if path in _DIMS:
        return _DIMS[path]
    parts = path.split("/")
    if parts[0] == "geometry":
        return ("element",)
    if parts[0] == "diagnostics":
        return ("time",)
    if parts[0] == "breaks":
        return ("break",)
    if len(parts) == 2:  # states/time, step, w, lat, lon
        return ("time", "element")[:ndim]
    if parts[1] == "fields":
        return ("time", "element", "category")[:ndim]
    return ("time", *(f"{parts[-1]}_{k}" for k in range(1, ndim)))


def _jsonable(attrs: dict) -> dict:
    return {k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in attrs.items()}


class ZarrWriter(HDF5Writer):
    """Element states, diagnostics, breaks, scene text and plugin versions in one Zarr store,
    written so that no fault corrupts it and restartable bit for bit (module docstring). The
    writing rules are the HDF5 writer's (one snapshot a commit, diagnostics with the
    snapshots, restart by copying the complete snapshots); the storage is Zarr's."""

    name = "zarr"
    appends = True
    folder = True
    params = {
        "compression": Param("zstd", "", "compression of the per-snapshot arrays (zstd: Zarr's "
                             "default; none: larger stores, faster writes)", type=str,
                             choices=("zstd", "none")),
    }

    # -------------------------------------------------------------- opening
    def open(self, ctx) -> None:
        import zarr
        from zarr.storage import LocalStore

        self.target = Path(self.path)
        again = self._ino
        self._again = again is not None and self.target.exists() and (
            self.target.stat().st_ino == again)
        self.partial = partial_path(self.target)
        self.replace = self.target.exists()
        self.published = False
        self.lock = None
        self.root = None
        self.comp = None if self.p["compression"] == "none" else "auto"
        self._padded: set[int] = set()
        self._last_state = None
        self._last_diag = None
        self._diag_rows: list[dict] = []
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DataError(f"{self.target}: cannot create its folder: {exc}") from None
        self._check_space(ctx)
        try:
            self.store = LocalStore(str(self.partial))
            self.root = zarr.open_group(self.store, mode="w-", zarr_format=3)
            self._layout(ctx)
            self._copied = self._copy_restart(ctx)
            self._flush()
            self.lock = RunLock(self.partial)
        except (OSError, RuntimeError, ValueError, TypeError) as exc:
            self._discard()
            what = "disk full" if is_disk_full(exc) else f"cannot create the output store: {exc}"
            raise DataError(f"{self.target}: {what}; nothing written (an existing store is "
                            "untouched)") from None
        if self._copied:
            self._publish()
        self._ino = os.stat(self.partial if not self.published else self.target).st_ino

    def _array(self, path: str, row, chunks=None, data=None):
        """A new array at ``path`` (below the root): ``data`` as it is, or empty and growing
        by rows shaped like ``row``."""
        group = self.root
        parts = path.split("/")
        for p in parts[:-1]:
            group = group.require_group(p)
        if data is not None:
            data = np.asarray(data)
            return group.create_array(parts[-1], data=data, compressors=self.comp and "auto",
                                      dimension_names=dimension_names(path, data.ndim))
        row = np.asarray(row)
        fill = pad_value(row.dtype) if is_padded(path[7:]) else 0
        arr = group.create_array(
            parts[-1], shape=(0, *row.shape), dtype=row.dtype, fill_value=fill,
            chunks=chunks or ((1, *(max(d, 1) for d in row.shape)) if row.ndim else (256,)),
            compressors=(self.comp if row.ndim else None) or None,
            dimension_names=dimension_names(path, row.ndim + 1))
        if is_padded(path[7:]):
            self._padded.add(id(arr))
        return arr

    def _layout(self, ctx) -> None:
        from siku_core.contact_law import BREAK_MODES
        from siku_core.diagnostics import catalogue

        st = ctx.state
        self.root.attrs.update({
            "siku_version": __version__, "siku_plugin_api": PLUGIN_API_VERSION,
            "layout": LAYOUT, "title": ctx.scene.cfg.title,
            "scene_file": str(ctx.scene.path or ""),
            "scene_sha256": hashlib.sha256(ctx.scene.text.encode()).hexdigest(),
            "dt": ctx.dt, "dt_requested": ctx.dt_requested,
            "start": ctx.start.isoformat() if ctx.start else "", "n_steps": ctx.n_steps,
            "seed": ctx.seed, "n_elements": st.n, "radius": ctx.radius,
            "scene": ctx.scene.text,
            "run_record": json.dumps(ctx.run_record(), default=str),
            "components": json.dumps(ctx.component_descriptions(), default=str)})
        self.root.create_group("plugins", attributes=dict(ctx.plugin_versions()))
        for k in GEOMETRY:
            self._array(f"geometry/{k}", None, data=getattr(st, k))
        self.rows = {name: self._array(f"states/{name}", row)
                     for name, row in self._state_rows(ctx).items()}
        self.step_ds = self._array("states/step", np.int64(0))
        self.diag = {k: self._array(f"diagnostics/{k}", np.asarray(v))
                     for k, v in ctx.diagnostics().items()}
        self.breaks = None
        if ctx.contacts is not None and ctx.contacts.joint_slots:
            cols = {"time": np.float64(0), "joint": np.int64(0), "i": np.int64(0),
                    "j": np.int64(0), "lat": np.float64(0), "lon": np.float64(0),
                    "mode": np.int8(0)}
            self.breaks = {k: self._array(f"breaks/{k}", v) for k, v in cols.items()}
            self.root["breaks"].attrs.update({f"mode_{c}": n for c, n in BREAK_MODES.items()})
        self._describe(ctx, catalogue(ctx.registry))

    def _describe(self, ctx, diagnostics) -> None:
        """The attributes of every array (``siku_io.output.layout.dataset_attrs``), as the
        HDF5 writer's."""
        epoch = ctx.start.strftime("%Y-%m-%d %H:%M:%S") if ctx.start else None
        declared = ctx.field_catalogue()
        standard = ctx.standard_names()
        arrays = [(f"geometry/{k}", self.root[f"geometry/{k}"]) for k in GEOMETRY]
        arrays += [(f"states/{k}", a) for k, a in self.rows.items()]
        arrays += [("states/step", self.step_ds)]
        arrays += [(f"diagnostics/{k}", a) for k, a in self.diag.items()]
        arrays += [(f"breaks/{k}", a) for k, a in (self.breaks or {}).items()]
        for path, arr in arrays:
            dtype = np.dtype(arr.dtype)
            arr.attrs.update(_jsonable(dataset_attrs(path, diagnostics, declared, epoch,
                                                     dtype, standard)))

    # -------------------------------------------------------------- the storage
    def _extend(self, arr, values) -> None:
        values = np.asarray(values)
        if not len(values):
            return
        n, rows = arr.shape[0], len(values)
        shape = tuple(arr.shape[1:])
        if id(arr) in self._padded:  # ragged rows: the array widens to the longest
            shape = (max(shape[0], values.shape[1]), *shape[1:])
            arr.resize((n + rows, *shape))
            arr[n:n + rows, :values.shape[1]] = values
            return
        arr.resize((n + rows, *shape))
        arr[n:n + rows] = values.reshape((rows, *shape))

    def _grow(self, arr, value) -> None:
        self._extend(arr, np.asarray(value)[None])

    def _set_geometry(self, name: str, values) -> None:
        self.root[f"geometry/{name}"][...] = values

    def _flush(self, final: bool = True) -> None:
        """Commit (``final``, after a commit's last row): the root ``zarr.json`` with every
        array's shape (consolidated metadata), replaced in one rename. Before (the new rows of
        a commit written, ``states/step``'s not yet) nothing is to be done: every file is
        already on disk, and readers see no row of the commit."""
        import zarr

        if not final:
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # consolidated metadata: not in the v3 spec yet
            zarr.consolidate_metadata(self.store)

    def _publish(self) -> None:
        """Put the store in place, then write on at its new place."""
        super()._publish()
        self._reopen(self.target)

    def _reopen(self, where: Path) -> None:
        """Every array of the store, opened again at ``where`` (a folder renamed)."""
        import zarr
        from zarr.storage import LocalStore

        self.store = LocalStore(str(where))
        self.root = zarr.open_group(self.store, mode="r+", use_consolidated=False)
        self.rows = {k: self.root[f"states/{k}"] for k in self.rows}
        self.step_ds = self.root["states/step"]
        self.diag = {k: self.root[f"diagnostics/{k}"] for k in self.diag}
        if self.breaks is not None:
            self.breaks = {k: self.root[f"breaks/{k}"] for k in self.breaks}
        self._padded = {id(a) for k, a in self.rows.items() if is_padded(k)}

    # -------------------------------------------------------------- faults and closing
    def _seal(self, close: bool = True) -> None:
        """Stop writing: every write already reached its file (nothing is buffered)."""
        self.root = None

    def _discard(self, close: bool = True) -> None:
        self._seal()
        shutil.rmtree(self.partial, ignore_errors=True)

    def close(self, ctx) -> None:
        from siku_core.run.outputs import settle

        self._seal()
        settle(self)

    @classmethod
    def owns(cls, path) -> bool:
        from .marks import is_zarr_output

        return is_zarr_output(path)


def export_zarr(path, target=None, overwrite: bool = False) -> Path:
    """Write the CF trajectory layout of ``siku export`` (``siku_io.output.netcdf``) of a siku
    output (HDF5 file or Zarr store) as a Zarr store (default: beside it, ``.zarr``): built
    beside the target and put in place whole."""
    from .marks import is_hdf5_output, is_zarr_output, writable
    from .netcdf import cf_dataset
    from .results import damaged, require_snapshot

    path = Path(path)
    target = Path(target) if target else path.with_suffix(".zarr")
    inputs = [("the exported file", path)]
    if target.resolve() != path.resolve():
        writable(target, "zarr export", overwrite=overwrite, inputs=inputs)
    if not path.exists():
        raise DataError(f"{path}: output file not found")
    if not (is_hdf5_output(path) or is_zarr_output(path)):
        raise DataError(f"{path}: is not a siku output (HDF5 file or Zarr store); siku export "
                        "reads the output of a run")
    target = writable(target, "zarr export", overwrite=overwrite, inputs=inputs)
    with damaged(path):
        require_snapshot(path, "export")
        ds = cf_dataset(path)
    part = partial_path(target)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # consolidated metadata: not in the v3 spec yet
            ds.to_zarr(part, mode="w-", zarr_format=3, consolidated=True)
        from siku_core.run.outputs import fsync_path, publish

        publish(part, target, replace=overwrite)
    except DataError:
        shutil.rmtree(part, ignore_errors=True)
        raise
    except Exception as exc:  # noqa: BLE001 - every library's error of a failed write
        shutil.rmtree(part, ignore_errors=True)
        why = "disk full" if is_disk_full(exc) else f"cannot write: {str(exc)[:300]}"
        raise DataError(f"{target}: {why} while writing the zarr export; nothing written (an "
                        "existing store is untouched)") from None
    fsync_path(target)
    return target


@hookimpl
def siku_register_writers():
    return [ZarrWriter]
