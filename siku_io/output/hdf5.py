"""HDF5 output (h5py) that a crash, a kill or a full disk cannot corrupt, and bit-for-bit
restart.

File layout (``layout`` = 2)::

    /                  attrs: siku_version, siku_plugin_api, layout, title, scene_file,
                              scene_sha256, dt [s], start (ISO or ""), n_steps (steps the
                              scene asks for), seed, n_elements, radius [m]; nothing about
                              when or where it was written, so the same scene, seed and
                              versions give the same file, byte for byte
    /scene             the scene file text, verbatim (with --set and --extend overrides noted)
    /run_record        JSON: what the run depends on (effective scene, components with every
                       parameter, versions): a restart compares it with its own
    /plugins           attrs: package -> version of every package that provided a component
    /components        JSON: name and parameters of every component of the run
    /geometry          vert_offsets, verts [m], m [kg], I [kg m²], area [m²], thickness [m],
                       radius [m], flags, material, floe (floe index of each element, -1: none):
                       the elements at the file's first snapshot (a restart that continues the
                       file keeps them; one written to another file starts there)
    /states            the snapshots: step, time [s], q (T,N,4), V (T,N,2) [m/s], w (T,N)
                       [rad/s], lat, lon (T,N) [deg], fields/NAME (T,N) per-element fields
                       (speed, damage, stress, declared ones), history/KEY/NAME (T,...) every
                       component's history (joints, declared fields): restarts read the last
    /diagnostics       step, time [s] and one series per diagnostic, attrs units and
                       long_name (siku_core.diagnostics.DIAGNOSTICS); its rows are written
                       with the snapshots, so they end where the snapshots end
    /breaks            one row per broken joint, in the order they broke: time [s] (model
                       time of the state that broke it), joint, i, j (element indices), lat,
                       lon [deg] (joint midpoint when written), mode (attrs: code -> name)

How nothing is lost (``docs/explanation/outputs.md``):

* The file is built beside the target (``.NAME.PID.partial``) and put in place atomically once
  it holds its first snapshot; an existing file is replaced only when the engine allows it
  (``--overwrite``, or a restart continuing the same file, which copies the earlier rows).
* The file is written in HDF5's single-writer/multiple-reader (SWMR) mode, whose ordered
  flushes keep the file consistent on disk after every write, so a kill at any moment leaves a
  file that opens. A snapshot is committed in two flushes: first every dataset's new row, then
  the new row of ``/states/step``. **The number of complete snapshots is the length of
  ``/states/step``** (likewise ``/diagnostics/step`` and ``/breaks/time``); after a fault other
  datasets may hold the rows of the commit it cut short, whose data may not have reached the
  disk. :func:`open_results`, :func:`n_snapshots` and :func:`last_snapshot` apply this rule.
* A write that fails (full disk, quota, file-size limit) stops the run with a one-line error
  naming the last snapshot safely on disk; nothing more is written to the file, and its
  "open for writing" mark is cleared so that it opens everywhere.
* A killed run leaves that mark set (HDF5 then refuses a plain ``h5py.File(path)``);
  :func:`open_results` (used by every siku command) clears it when no process holds the file,
  as ``h5clear -s`` does; ``h5py.File(path, "r", swmr=True)`` reads such a file as it is.
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from siku_core import PLUGIN_API_VERSION, DataError, Param, __version__, hookimpl
from siku_core.interfaces import Writer
from siku_core.run.outputs import RunLock, fsync_path, is_disk_full, partial_path, publish, settle

from .padded import append_padded, is_padded, made_padded, new_padded
from .results import (
    LAYOUT,
    clear_open_mark,
    n_snapshots,
    open_results,
)

from .layout import GEOMETRY as _GEOMETRY
#: files given up after a failed write, kept open (on /dev/null) until the process ends
_SEALED: list = []


# ---------------------------------------------------------------------------- writing
def _create(group, name: str, row: np.ndarray, compression: str | None):
    """An empty dataset growing by rows shaped like ``row``."""
    row = np.asarray(row)
    return group.create_dataset(  # (a zero-length row, e.g. no joints, still needs chunks > 0)
        name, shape=(0, *row.shape), maxshape=(None, *(d or None for d in row.shape)),
        dtype=row.dtype, chunks=(1, *(max(d, 1) for d in row.shape)) if row.ndim else (256,),
        compression=compression if row.ndim else None,
    )


def _append(ds, values, rows: int) -> None:
    """Append ``rows`` rows ``values`` (shaped ``(rows, *row_shape)``, or one row when
    ``rows == 1``) to ``ds`` along its first axis.

    Through h5py's low-level dataset calls (extent, hyperslab, write): about a third of the
    cost of ``ds.resize`` and slice assignment, which build selections in Python; a snapshot
    writes some fifty datasets. HDF5 converts the values to the dataset's type as the
    high-level call does."""
    from h5py import h5s

    if made_padded(ds):  # per-contact rows (siku_io.output.padded)
        return append_padded(ds, values, rows)
    did = ds.id
    shape = did.shape
    arr = np.asarray(values)
    if arr.dtype.kind not in "biuf" or 0 in shape[1:]:
        n = shape[0]  # strings, empty rows: the high-level call
        ds.resize(n + rows, axis=0)
        if rows == 1 and arr.ndim == len(shape) - 1:
            ds[n] = arr
        else:
            ds[n:] = arr
        return
    arr = np.ascontiguousarray(arr).reshape((rows, *shape[1:]))
    n = shape[0]
    did.set_extent((n + rows, *shape[1:]))
    fspace = did.get_space()
    fspace.select_hyperslab((n,) + (0,) * (len(shape) - 1), arr.shape)
    did.write(h5s.create_simple(arr.shape), fspace, arr)


def _grow(ds, value) -> None:
    _append(ds, value, 1)


def _extend(ds, values: np.ndarray) -> None:
    if len(values):
        _append(ds, values, len(values))


class HDF5Writer(Writer):
    """Element states, diagnostics, breaks, scene text and plugin versions in one HDF5 file,
    written so that no fault corrupts it (module docstring)."""

    name = "hdf5"
    appends = True  # a restart continues the file
    #: the open HDF5 file (``None``: none open)
    f = None
    #: the inode of the file this writer made in an earlier ``run()`` of the same simulation
    #: (``None``: none), which a second ``run()`` continues
    _ino: int | None = None
    params = {
        "compression": Param("none", "", "compression of the per-snapshot datasets (gzip, lzf: "
                             "smaller files, slower writes)", type=str,
                             choices=("gzip", "lzf", "none")),
    }

    # -------------------------------------------------------------- opening
    def open(self, ctx) -> None:
        import h5py

        self.target = Path(self.path)
        # a second run() of the same simulation continues the file this writer made
        again = self._ino
        self._again = again is not None and self.target.exists() and (
            self.target.stat().st_ino == again)
        self.partial = partial_path(self.target)
        self.replace = self.target.exists()  # the engine allowed it (--overwrite or restart)
        self.published = False
        self.lock = None
        self.f = None
        self.comp = None if self.p["compression"] == "none" else self.p["compression"]
        self._last_state = None  # (step, time) of the last committed snapshot
        self._last_diag = None
        self._diag_rows: list[dict] = []  # diagnostics rows kept until the next snapshot
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DataError(f"{self.target}: cannot create its folder: {exc}") from None
        self._check_space(ctx)
        swmr = False
        try:
            self.f = h5py.File(self.partial, "w", libver="latest")
            self._layout(ctx)
            self._copied = self._copy_restart(ctx)
            swmr = True
            self.f.swmr_mode = True
            self.lock = RunLock(self.partial)
        except (OSError, RuntimeError, ValueError) as exc:
            # closed (so that HDF5 forgets the file: a later file of this process may get the
            # same inode) unless the switch to SWMR mode failed, after which HDF5 cannot close
            self._discard(close=not swmr)
            what = "disk full" if is_disk_full(exc) else f"cannot create the output file: {exc}"
            raise DataError(f"{self.target}: {what}; nothing written (an existing file is "
                            "untouched)") from None
        if self._copied:  # the file already holds real snapshots
            self._publish()
        self._ino = os.stat(self.partial if not self.published else self.target).st_ino

    def _check_space(self, ctx) -> None:
        """Refuse to start when the disk (or the file-size limit) cannot hold the file with its
        first snapshot, and warn when it cannot hold the whole run."""
        import resource
        import shutil
        import warnings

        rows = self._state_rows(ctx)
        row = sum(np.asarray(v).nbytes for v in rows.values()) + 8
        n_diag = len(ctx.diagnostics())
        geometry = sum(np.asarray(getattr(ctx.state, k)).nbytes for k in _GEOMETRY)
        series = n_diag + 8 + sum(np.ndim(v) == 0 for v in rows.values())  # 2 KiB chunks
        first = 32768 + 2560 * series + 512 * (len(rows) + len(_GEOMETRY)) + geometry + row + len(
            ctx.scene.text)
        snaps = ctx.n_steps // max(ctx.snapshot_every, 1) + 2
        diags = ctx.n_steps // max(ctx.diagnostics_every, 1) + 2
        whole = first + snaps * row + diags * 8 * n_diag
        free = shutil.disk_usage(self.target.parent).free
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if limit != resource.RLIM_INFINITY:
            free = min(free, limit)
        if first > free:
            raise DataError(f"{self.target}: disk full: {free} bytes free (or allowed per file), "
                            f"the file needs about {first} to hold its first snapshot; nothing "
                            "written (an existing file is untouched)")
        if whole > free:
            warnings.warn(f"{self.target}: the run will write about {whole / 1e6:.3g} MB but only "
                          f"{free / 1e6:.3g} MB are free; it stops with a message naming the last "
                          "snapshot on disk if the disk fills", stacklevel=2)

    def _layout(self, ctx) -> None:
        f = self.f
        st = ctx.state
        f.attrs["siku_version"], f.attrs["siku_plugin_api"] = __version__, PLUGIN_API_VERSION
        f.attrs["layout"] = LAYOUT
        f.attrs["title"] = ctx.scene.cfg.title
        f.attrs["scene_file"] = str(ctx.scene.path or "")
        f.attrs["scene_sha256"] = hashlib.sha256(ctx.scene.text.encode()).hexdigest()
        f.attrs["dt"] = ctx.dt
        f.attrs["dt_requested"] = ctx.dt_requested
        f.attrs["start"] = ctx.start.isoformat() if ctx.start else ""
        f.attrs["n_steps"] = ctx.n_steps
        f.attrs["seed"] = ctx.seed
        f.attrs["n_elements"] = st.n
        f.attrs["radius"] = ctx.radius
        f.create_dataset("scene", data=ctx.scene.text)
        f.create_dataset("run_record", data=json.dumps(ctx.run_record(), default=str))
        g = f.create_group("plugins")
        for pkg, ver in ctx.plugin_versions().items():
            g.attrs[pkg] = ver
        f.create_dataset("components", data=json.dumps(
            ctx.component_descriptions(), default=str))
        geo = f.create_group("geometry")
        for k in _GEOMETRY:
            geo.create_dataset(k, data=getattr(st, k))
        s = f.create_group("states")
        self.rows = {}
        for name, row in self._state_rows(ctx, fields=True).items():
            self.rows[name] = (new_padded if is_padded(name) else _create)(s, name, row, self.comp)
        self.step_ds = _create(s, "step", np.int64(0), None)
        self.diag = {}
        dg = f.create_group("diagnostics")
        from siku_core.diagnostics import catalogue

        known = catalogue(ctx.registry)
        for k, v in ctx.diagnostics().items():
            self.diag[k] = _create(dg, k, np.asarray(v), None)
            if k in known:
                self.diag[k].attrs["units"], self.diag[k].attrs["long_name"] = known[k]
        self.breaks = None
        if ctx.contacts is not None and ctx.contacts.joint_slots:
            from siku_core.contact_law import BREAK_MODES

            b = f.create_group("breaks")
            for code, name in BREAK_MODES.items():
                b.attrs[f"mode_{code}"] = name
            cols = {"time": np.float64(0), "joint": np.int64(0), "i": np.int64(0),
                    "j": np.int64(0), "lat": np.float64(0), "lon": np.float64(0),
                    "mode": np.int8(0)}
            self.breaks = {k: b.create_dataset(k, shape=(0,), maxshape=(None,), dtype=v.dtype,
                                               chunks=(256,)) for k, v in cols.items()}
        self._describe(ctx, known)

    def _describe(self, ctx, diagnostics) -> None:
        """``units`` and ``long_name`` on every dataset (``siku_io.output.layout``), CF flag
        meanings on the coded ones, and the epoch of the time axes when the scene has a start."""
        from siku_io.output.layout import dataset_attrs

        epoch = ctx.start.strftime("%Y-%m-%d %H:%M:%S") if ctx.start else None
        declared = ctx.field_catalogue()
        for path in _leaves(self.f):
            ds = self.f[path]
            ds.attrs.update(dataset_attrs(path, diagnostics, declared, epoch, ds.dtype,
                                          ctx.standard_names()))

    def _state_rows(self, ctx, fields: bool = True) -> dict[str, np.ndarray]:
        """Every per-snapshot dataset's row for the current state, by path in ``/states``."""
        from siku_io.output.layout import state_rows

        return state_rows(ctx)

    # the storage primitives (a subclass writes another format: siku_io.output.zarr_store)
    _extend = staticmethod(_extend)
    _grow = staticmethod(_grow)

    def _set_geometry(self, name: str, values) -> None:
        """Replace the values of ``/geometry/NAME`` (same shape)."""
        self.f["geometry"][name][...] = values

    def _copy_restart(self, ctx) -> bool:
        """Continuing the file a restart read: copy its ``/geometry`` (the elements at its first
        snapshot), its complete snapshots, the diagnostics up to the restart step and the
        breaks before it. ``False`` when writing another file."""
        if self._again:
            src, step = self.target, ctx.step_index
        else:
            src = ctx.restart_path
            if ctx.restarted_from is None or src is None or not self.target.exists():
                return False
            if not os.path.samefile(src, self.target):
                return False
            step = ctx.restarted_from
        with open_results(src) as g:
            for k in _GEOMETRY:  # the elements at the file's first snapshot, not the restart's
                self._set_geometry(k, g["geometry"][k][...])
            n = n_snapshots(g)
            s = g["states"]
            names = {k for k in _leaves(s) if k != "step"}
            if names != set(self.rows):
                raise DataError(
                    f"{self.target}: cannot continue this file in place: its snapshots hold "
                    f"{', '.join(sorted(names - set(self.rows))) or 'no'} extra and "
                    f"{', '.join(sorted(set(self.rows) - names)) or 'no'} missing datasets for "
                    "this scene; write the continued run to another --out")
            for name, ds in self.rows.items():
                self._extend(ds, s[name][:n])
            self._extend(self.step_ds, s["step"][:n])
            d = g["diagnostics"]
            if "step" in d:
                keep = int(np.searchsorted(d["step"][:d["step"].shape[0]], step, side="right"))
                for k, ds in self.diag.items():
                    if k in d:
                        self._extend(ds, d[k][:keep])
                if keep:
                    self._last_diag = int(d["step"][keep - 1])
            if self.breaks is not None and "breaks" in g:
                b = g["breaks"]
                t = b["time"][:b["time"].shape[0]]
                keep = int(np.count_nonzero(t < step * ctx.dt))
                for k, ds in self.breaks.items():
                    self._extend(ds, b[k][:keep])
        self._last_state = (step, step * ctx.dt)
        return True

    # -------------------------------------------------------------- writing
    def write_state(self, ctx) -> None:
        if self._last_state is not None and self._last_state[0] == ctx.step_index:
            return
        data = [(self.rows[k], v) for k, v in self._state_rows(ctx).items() if k in self.rows]
        markers = [(self.step_ds, np.int64(ctx.step_index))]
        ddata, dmarkers = self._diagnostics_upto(ctx.step_index)
        data += ddata
        markers = dmarkers + markers
        cm = ctx.contacts
        if self.breaks is not None and cm is not None:
            rows = cm.take_breaks()
            data += [(self.breaks[k], v) for k, v in rows.items() if k != "time"]
            markers.insert(0, (self.breaks["time"], rows["time"]))
        self._commit(data, markers, f"the snapshot at step {ctx.step_index}")
        self._last_state = (ctx.step_index, ctx.time)
        if not self.published:
            self._publish()

    def write_diagnostics(self, ctx, diag: Mapping[str, Any]) -> None:
        """Keep one row of diagnostics; the rows go to the file with the next snapshot (one
        write per series instead of one per row), so the file's diagnostics end where its
        snapshots end."""
        if self._last_diag == diag["step"]:
            return
        self._diag_rows.append({k: v for k, v in diag.items() if k in self.diag})
        self._last_diag = diag["step"]

    def _diagnostics_upto(self, step: int) -> tuple[list, list]:
        """The kept diagnostics rows up to ``step`` as (data, markers) of one commit."""
        rows = [r for r in self._diag_rows if r["step"] <= step]
        self._diag_rows = [r for r in self._diag_rows if r["step"] > step]
        if not rows:
            return [], []
        data = [(ds, np.array([r[k] for r in rows], dtype=ds.dtype))
                for k, ds in self.diag.items() if k != "step"]
        return data, [(self.diag["step"], np.array([r["step"] for r in rows], dtype=np.int64))]

    def _commit(self, data, markers, what: str) -> None:
        """Write the rows ``data`` and flush, then the ``markers`` (the datasets whose length
        counts complete rows) and flush: a kill in between leaves the rows uncounted."""
        try:
            for phase in (data, markers):
                for ds, v in phase:
                    if np.ndim(v) == 1 and len(ds.shape) == 1:
                        self._extend(ds, v)
                    else:
                        self._grow(ds, v)
                self._flush(final=phase is markers)
        except (OSError, RuntimeError, ValueError) as exc:
            self._abandon(exc, what)

    def _flush(self, final: bool = True) -> None:
        """Make what was written reach the file (SWMR's ordered flush); ``final``: the last
        flush of a commit."""
        self.f.flush()

    def _publish(self) -> None:
        publish(self.partial, self.target, replace=self.replace)
        self.published = True
        fsync_path(self.target)
        self._ino = self.target.stat().st_ino

    # -------------------------------------------------------------- faults and closing
    def _seal(self, close: bool = True) -> None:
        """Stop every further write to the file: HDF5's descriptor now points at ``/dev/null``,
        so closing the file (which flushes what HDF5 still holds) writes nothing to it and
        HDF5 closes cleanly."""
        f = self.f
        if f is None or not f.id.valid:
            return
        try:
            fd = f.id.get_vfd_handle()
            null = os.open(os.devnull, os.O_RDWR)
            os.dup2(null, fd)
            os.close(null)
        except (OSError, ValueError, TypeError):
            pass
        if close:
            try:
                f.close()
            except Exception:  # noqa: BLE001 - the close is expected to fail on the sealed file
                pass
        else:  # HDF5 may be in no state to close it (a failed switch to SWMR mode): keep it
            _SEALED.append(f)
        self.f = None

    def _abandon(self, exc: BaseException, what: str) -> None:
        self._seal()
        if self.lock is not None:
            self.lock.release()
            self.lock = None
        why = "disk full" if is_disk_full(exc) else f"write failed ({exc})"
        if not self.published:
            self._discard()
            raise DataError(f"{self.target}: {why} while writing {what}; nothing written (an "
                            "existing file is untouched)") from None
        try:
            clear_open_mark(self.target)
        except (OSError, DataError):
            pass
        step, t = self._last_state if self._last_state else (None, None)
        held = (f"holds complete snapshots to step {step} (t = {t:g} s); continue with "
                f"--restart {self.target}") if step is not None else "holds no snapshot"
        raise DataError(f"{self.target}: {why} while writing {what}; the file {held}") from None

    def _discard(self, close: bool = True) -> None:
        self._seal(close)
        try:
            os.unlink(self.partial)
        except OSError:
            pass

    def close(self, ctx) -> None:
        f = self.f
        if f is not None and f.id.valid:
            try:
                f.close()
            except (OSError, RuntimeError) as exc:
                self._abandon(exc, "the end of the file")
        self.f = None
        settle(self)

    @classmethod
    def owns(cls, path) -> bool:
        from .marks import is_hdf5_output

        return is_hdf5_output(path)

    # -------------------------------------------------------------- restart
    @classmethod
    def read_restart(cls, path, ctx) -> dict:
        """The last complete snapshot of ``path``: ``step``, ``q``, ``V``, ``w``, every
        component's ``history``, and the file's ``record`` and ``n_steps`` (the engine puts
        them into the run: :meth:`siku_core.interfaces.Writer.read_restart`)."""
        from .results import restart_snapshot

        return restart_snapshot(Path(path), ctx.state.n, ctx.history())


def _leaves(group, prefix: str = "") -> list[str]:
    out = []
    for k, v in group.items():
        if hasattr(v, "items"):
            out.extend(_leaves(v, f"{prefix}{k}/"))
        else:
            out.append(prefix + k)
    return out


class MemoryWriter(HDF5Writer):
    """The snapshots of a run kept in memory, in the HDF5 file's layout, for
    ``Simulation(scene, out="memory")`` and ``Simulation.to_xarray()``: nothing is written to
    disk; :meth:`dataset` reads them as ``xr.open_dataset(FILE, engine="siku")`` reads the file
    of the same run (the same variables, units, coordinates and values)."""

    name = "memory"
    appends = False
    #: told apart from the writers of files by the engine (``Simulation.to_xarray``)
    in_memory = True

    def open(self, ctx) -> None:
        import io

        import h5py

        if self.path is not None:
            from siku_core.errors import SceneError

            raise SceneError(f"{ctx.scene.where(self.table)}: writer "
                             "'memory' keeps a run's snapshots for Python "
                             "(Simulation(scene, out=\"memory\")); a file is written by "
                             "'hdf5' or 'netcdf'")
        self.target = Path("<memory>")
        self.published, self.lock, self._copied = True, None, False
        self.comp = None if self.p["compression"] == "none" else self.p["compression"]
        if self.f is not None:  # a second run() continues the snapshots,
            self._last_state = (ctx.step_index, ctx.time)  # as HDF5Writer continues its file
            return
        self.buffer = io.BytesIO()
        self._last_state = None
        self._last_diag = None
        self._diag_rows = []
        self.f = h5py.File(self.buffer, "w", libver="latest")
        self._layout(ctx)

    def _publish(self) -> None:
        self.published = True

    def holds_snapshots(self) -> bool:
        """Whether the run has kept snapshots here (:meth:`dataset` reads them)."""
        return self.f is not None

    def _abandon(self, exc: BaseException, what: str) -> None:
        raise DataError(f"the run's snapshots held in memory: {what} failed ({exc})") from None

    def close(self, ctx) -> None:
        """The snapshots stay (in memory, open): a later ``run()`` continues them."""
        if self.f is not None:
            self.f.flush()

    @classmethod
    def owns(cls, path) -> bool:
        return False  # it never makes a file

    @classmethod
    def read_restart(cls, path, ctx) -> dict:
        raise DataError(f"{path}: the 'memory' writer keeps no file to restart from")

    def dataset(self, group: str | None = None, outlines: bool = True,
                decode_times: bool = True):
        """The snapshots kept so far as an ``xarray.Dataset``
        (:func:`siku_io.output.xr.dataset_of`); ``group``: ``None``, ``"diagnostics"``,
        ``"breaks"``."""
        from siku_io.output.xr import dataset_of

        if self.f is None:
            raise DataError("the run keeps no snapshot in memory yet (run or advance it first)")
        self.f.flush()
        return dataset_of(self.f, "<memory>", group, outlines, decode_times,
                          source="run held in memory")


@hookimpl
def siku_register_writers():
    return [HDF5Writer, MemoryWriter]
