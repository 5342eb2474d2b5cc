"""CF-NetCDF output of element results: ``siku export OUT.h5 --to netcdf`` and the writer
``[output] writer = "netcdf"``.

Layout of ``siku export`` (CF 1.8, checked with the IOOS ``compliance-checker``): every
element is a discrete sampling geometry feature of type ``trajectory`` (``element`` is its
``trajectory_id``) in the multidimensional array representation, sampled at the snapshots:

* dimensions ``element``, ``obs`` (the snapshots), ``node`` (the polygon vertices of all
  elements, in order);
* ``time(element, obs)`` (``seconds since`` the scene's start, or 1970-01-01 when it sets none:
  the ``comment`` says so; the same times for every element), ``lon``/``lat(element, obs)``
  [degrees] of the centroids;
* per element and snapshot: ``u``/``v`` (``eastward_sea_ice_velocity``, ``northward_...``) [m/s],
  ``spin`` [rad/s], every per-element field (``speed``, ``damage``, ``stress_ee`` ... [N/m]);
* per element: ``area`` [m²], ``thickness`` (``sea_ice_thickness``) [m], ``mass`` [kg],
  ``flags`` (``flag_values``/``flag_meanings``), ``material``, ``floe``;
* outlines as CF polygon geometry: the container ``outline`` (``geometry_type = "polygon"``)
  with ``node_count(element)`` and ``node_lon``/``node_lat(node)``: the polygons at the first
  time (CF geometry does not vary in time); ``node_lon_t``/``node_lat_t(node, obs)`` hold them
  at every snapshot.

The writer (a file that grows while the run goes) holds the same variables with the record
dimension ``time`` first, as the NetCDF-3 format requires: ``time(time)``, ``lon(time,
element)``... (CF's "incomplete" orientation; ``siku export`` of the run's HDF5 output gives the
trajectory form above).

The writer writes the NetCDF-3 64-bit-offset format in unbuffered shared mode with fill values
on: a new record is written ``time`` first (which fills the record's other variables with
missing values, NaN), then variable by variable, ``step`` last; a kill leaves at most one
record whose ``step`` is missing, which :func:`complete_records` leaves out and any other
reader sees as missing values, never as numbers. The file is built beside its target and put
in place with its first snapshot, as the HDF5 writer's (``docs/explanation/outputs.md``).

A restart continues the writer's own file, as the HDF5 writer does (``appends``): the new file
begins with the old file's complete records before the restart's step, copied value for value,
and replaces the old one with its first new snapshot, so a killed run continued with
``--restart`` leaves one file equal to an uninterrupted run's (:meth:`NetCDFWriter.continued`).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from siku_core import DataError, Param, hookimpl
from siku_core.fields import ENGINE_FIELDS, STATE_FIELDS
from siku_core.interfaces import Writer

FILL_INT = np.int32(-2147483647)
#: files given up after a failed write that the library could not close (kept to the end)
_SEALED: list = []
_STATIC = {"area": "area", "thickness": "thickness", "mass": "mass",
           "moment_of_inertia": "moment_of_inertia", "flags": "flags", "material": "material",
           "floe": "floe"}


def _flag_attrs() -> dict:
    """CF ``flag_values`` (int32) and ``flag_meanings`` of the element kinds."""
    from siku_core.state import FLAG_MEANINGS

    codes = sorted(FLAG_MEANINGS.values())
    names = {c: n for n, c in FLAG_MEANINGS.items()}
    return {"flag_values": np.array(codes, dtype=np.int32),
            "flag_meanings": " ".join(names[c] for c in codes)}


def cf_time_units(start: str) -> tuple[str, str]:
    """CF time units and a comment."""
    if start:
        stamp = start.replace("T", " ").replace("+00:00", "").replace("Z", "")[:19]
        return f"seconds since {stamp}", "model time 0 is the scene's start"
    return ("seconds since 1970-01-01 00:00:00",
            "model seconds since the start of the run: the scene sets no start date, so "
            "dates read as 1970-01-01 plus the model time")


def global_attrs(src_attrs: dict) -> dict:
    return {
        "Conventions": "CF-1.8",
        "featureType": "trajectory",
        "title": str(src_attrs.get("title", "")) or "siku run",
        "institution": "siku users",
        "source": f"siku {src_attrs.get('siku_version', '')} discrete-element sea-ice model",
        "history": str(src_attrs.get("source", "siku run")),
        "references": "siku documentation, docs/reference/output.md",
        "comment": "each element (an ice polygon) is a trajectory feature",
        **{f"siku_{k}": (v if isinstance(v, (int, float, str)) else str(v))
           for k, v in src_attrs.items() if k not in ("source",)},
    }


def cf_dataset(path):
    """The CF-NetCDF layout (module docstring) of a siku HDF5 output file, as an
    ``xarray.Dataset`` whose values are exactly those of the file."""
    import xarray as xr

    from siku_io.output.xr import open_output

    src = open_output(path, decode_times=False)
    units, comment = cf_time_units(str(src.attrs.get("start", "")))
    E, T = "element", "obs"
    src = src.rename({"time": "obs"})
    n = src.sizes[E]
    coords = {
        "time": xr.Variable((E, T), np.broadcast_to(src["obs"].values, (n, src.sizes[T])), {
            "standard_name": "time", "long_name": "time of the snapshot", "units": units,
            "calendar": "proleptic_gregorian", "axis": "T", "comment": comment}),
        "lon": xr.Variable((E, T), src["lon"].values.T, {
            "standard_name": "longitude", "units": "degrees_east",
            "long_name": "longitude of the element centroid"}),
        "lat": xr.Variable((E, T), src["lat"].values.T, {
            "standard_name": "latitude", "units": "degrees_north",
            "long_name": "latitude of the element centroid"}),
    }
    data = {
        "element": xr.Variable(E, np.arange(src.sizes[E], dtype=np.int32), {
            "cf_role": "trajectory_id", "long_name": "element index"}),
        "step": xr.Variable(T, src["step"].values.astype(np.int32), {
            "long_name": "step index of the snapshot", "units": "1",
            "_FillValue": FILL_INT}),
    }
    std = {k: f.standard_name for k, f in {**STATE_FIELDS, **ENGINE_FIELDS}.items()
           if f.standard_name}
    per = ["u", "v", "spin"] + [k for k in src.data_vars if src[k].dims[:2] == (T, E)
                                and k not in ("u", "v", "spin", "q", "V")]
    for k in per:
        a = dict(src[k].attrs)
        if k in std:  # the catalogue's (thickness: changed by processes, time-dependent)
            a["standard_name"] = std[k]
        if "flag_values" in a:
            a["flag_values"] = np.asarray(a["flag_values"], dtype=src[k].dtype)
        a["coordinates"] = "time lat lon"
        a["geometry"] = "outline"
        data[k] = xr.Variable((E, T, *src[k].dims[2:]), np.swapaxes(src[k].values, 0, 1), a)
    for k, name in _STATIC.items():
        v = src[k]
        if v.dims != (E,):  # time-dependent here (processes): written with the records
            continue
        a = dict(v.attrs)
        if k == "thickness":
            a["standard_name"] = "sea_ice_thickness"
        vals = v.values.astype(np.int32) if v.dtype.kind == "i" else v.values
        if "flag_values" in a:
            a["flag_values"] = np.asarray(a["flag_values"], dtype=vals.dtype)
        data[name] = xr.Variable(E, vals, a)
    data["outline"] = xr.Variable((), np.int32(0), {
        "geometry_type": "polygon", "node_count": "node_count",
        "node_coordinates": "node_lon node_lat",
        "long_name": "element outlines at the first time"})
    data["node_count"] = xr.Variable(E, src["node_count"].values.astype(np.int32), {
        "long_name": "number of vertices of each element's polygon"})
    n0 = 0 if src.sizes[T] else None
    nl = src["node_lon"].values
    nt = src["node_lat"].values
    data["node_lon"] = xr.Variable("node", nl[n0] if n0 is not None else nl[:0, 0], {
        "units": "degrees_east", "standard_name": "longitude", "axis": "X",
        "long_name": "longitude of the polygon vertices at the first time"})
    data["node_lat"] = xr.Variable("node", nt[n0] if n0 is not None else nt[:0, 0], {
        "units": "degrees_north", "standard_name": "latitude", "axis": "Y",
        "long_name": "latitude of the polygon vertices at the first time"})
    data["node_lon_t"] = xr.Variable(("node", T), nl.T, {
        "units": "degrees_east", "long_name": "longitude of the polygon vertices"})
    data["node_lat_t"] = xr.Variable(("node", T), nt.T, {
        "units": "degrees_north", "long_name": "latitude of the polygon vertices"})
    out = xr.Dataset(data, coords, global_attrs(src.attrs))
    out = out.drop_vars("obs", errors="ignore")
    out.attrs["siku_plugins"] = src.attrs.get("plugins", "{}")
    return out


def export(path, target=None, overwrite: bool = False) -> Path:
    """Write the CF-NetCDF form of a siku HDF5 output file (default: beside it, ``.nc``)."""
    from .marks import is_hdf5_output, netcdf_kind, writable
    from .results import damaged

    path = Path(path)
    target = Path(target) if target else path.with_suffix(".nc")
    inputs = [("the exported file", path)]
    if target.resolve() != path.resolve():  # the output first: refused before any work
        writable(target, "export", overwrite=overwrite, inputs=inputs)
    if not path.is_file():
        raise DataError(f"{path}: output file not found")
    if not is_hdf5_output(path):
        kind = netcdf_kind(path)
        what = (f"a {kind} file of siku, already NetCDF" if kind else
                "not a siku HDF5 output file")
        raise DataError(f"{path}: is {what}; siku export reads the HDF5 output of a run")
    from .results import require_snapshot

    with damaged(path):
        require_snapshot(path, "export")
        ds = cf_dataset(path)
    return write_netcdf(ds, target, overwrite=overwrite, kind="export", inputs=inputs)


def write_netcdf(ds, target: Path, overwrite: bool = False, kind: str = "grid",
                 inputs=()) -> Path:
    """Write a dataset to ``target`` as NetCDF-4, built beside it and put in place atomically;
    an existing file is replaced only with ``overwrite``, and only when it is siku's own file
    of ``kind`` (``siku_io.output.marks``); never one of ``inputs`` (``(key, path)``)."""
    from .marks import writable, write_whole

    target = writable(target, kind, overwrite=overwrite, inputs=inputs)
    enc = {}
    for k, v in ds.variables.items():
        if np.issubdtype(v.dtype, np.floating):
            enc[k] = {"_FillValue": np.nan if k not in ds.coords else None}
        if k == "time" and np.issubdtype(v.dtype, np.datetime64):
            start = str(ds.attrs.get("start", ""))[:19].replace("T", " ") or "1970-01-01"
            enc[k] = {"units": f"seconds since {start}", "calendar": "proleptic_gregorian",
                      "dtype": "float64"}
    return write_whole(target, lambda part: ds.to_netcdf(part, format="NETCDF4",
                                                          engine="netcdf4", encoding=enc),
                       f"{kind} file", replace=overwrite)


def complete_records(path) -> int:
    """Complete snapshots of a NetCDF file the writer made: the records before the first whose
    ``step`` is missing."""
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        step = np.ma.getmaskarray(nc["step"][:])
        return int(np.argmax(step)) if step.any() else len(step)


class NetCDFWriter(Writer):
    """Element states as CF-NetCDF (``siku_io.output.netcdf``), written so that a kill leaves a file
    that opens and holds only real data (or values marked missing)."""

    name = "netcdf"
    appends = True  # a restart continues the file (NetCDFWriter.continued)
    #: the open NetCDF dataset (``None``: none open)
    nc = None
    params = {
        "outlines": Param(True, "", "write the polygon outlines at every snapshot "
                          "(node_lon_t, node_lat_t)", type=bool),
    }

    def open(self, ctx) -> None:
        import netCDF4

        from siku_core.run.outputs import RunLock, partial_path

        self.target = Path(self.path)
        self.partial = partial_path(self.target)
        self.replace = self.target.exists()
        self.published = False
        self.lock = None
        self.nc = None
        self.t = 0
        self._last = None
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            self.nc = netCDF4.Dataset(self.partial, "ws", format="NETCDF3_64BIT_OFFSET")
            self.nc.set_fill_on()
            self._define(ctx)
            self.t = self.continued(ctx)
            self.nc.sync()
            self.lock = RunLock(self.partial)
        except (OSError, RuntimeError, ValueError) as exc:
            self._discard()
            raise DataError(f"{self.target}: cannot create the output file: {exc}; nothing "
                            "written (an existing file is untouched)") from None

    def continued(self, ctx) -> int:
        """On a restart, when this writer's file exists: copy its complete records before the
        restart's step into the new file (the restart writes its step again, from the same
        state) and return how many; 0 otherwise. A file of another layout (other variables,
        another number of elements or nodes) is refused in one line: the old file is kept
        whole and the continuation goes to a new file."""
        import netCDF4

        if ctx.restarted_from is None or not self.target.exists():
            return 0
        if not self.owns(self.target):
            self._discard()
            raise DataError(f"{self.target}: exists and is not an output of the NetCDF writer; "
                            "siku never replaces a file it did not write: move it away or give "
                            "the writer another file")
        n = complete_records(self.target)
        with netCDF4.Dataset(self.target) as old:
            mine = {k: v.shape[1:] for k, v in self.nc.variables.items()
                    if v.dimensions[:1] == ("time",)}
            theirs = {k: v.shape[1:] for k, v in old.variables.items()
                      if v.dimensions[:1] == ("time",)}
            if mine != theirs:
                self._discard()
                diff = sorted(set(mine.items()) ^ set(theirs.items()))
                raise DataError(
                    f"{self.target}: cannot continue this file in place: its records differ "
                    f"from this scene's ({', '.join(f'{k}{list(s)}' for k, s in diff[:4])}); "
                    "the file is kept as it is: give the writer another file for the "
                    "continuation")
            keep = int(np.count_nonzero(np.asarray(old["step"][:n]) < ctx.step_index))
            # time first (it grows the records), step last, as write_state writes a record
            for k in ["time", *sorted(set(mine) - {"time", "step"}), "step"]:
                if keep:
                    self.nc[k][:keep] = old[k][:keep]
        return keep

    def _define(self, ctx) -> None:
        """The header of the file and its fixed data, in this order: the global attributes, the
        dimensions and coordinates, the per-snapshot records, the element geometry and the
        outlines."""
        start = ctx.start.isoformat() if ctx.start else ""
        self._define_attributes(ctx, start)
        self._define_coordinates(ctx, start)
        self._define_records(ctx)
        self._define_geometry(ctx)
        self._define_outlines(ctx)

    def _define_attributes(self, ctx, start: str) -> None:
        """The global attributes: the run's settings (``dt`` [s], ``radius`` [m], ...), the
        scene's text and the plugins' versions."""
        from siku_core import PLUGIN_API_VERSION, __version__

        st = ctx.state
        attrs = {"siku_version": __version__, "siku_plugin_api": PLUGIN_API_VERSION,
                 "title": ctx.scene.cfg.title, "start": start, "dt": ctx.dt,
                 "dt_requested": ctx.dt_requested, "seed": ctx.seed,
                 "radius": ctx.radius, "n_elements": st.n,
                 "n_steps": ctx.n_steps}
        attrs["source"] = f"siku {__version__} run of {ctx.scene.path or 'a scene'}"
        g = global_attrs(attrs)
        g["siku_scene"] = ctx.scene.text
        g["siku_plugins"] = json.dumps(ctx.plugin_versions())
        self.nc.setncatts(g)

    def _define_coordinates(self, ctx, start: str) -> None:
        """The dimensions (element, unlimited time, node) and the coordinates: ``time`` [s since
        the start], the snapshot's ``step`` (missing in an incomplete record) and ``element``."""
        nc, st = self.nc, ctx.state
        N = st.n
        nc.createDimension("element", N)
        nc.createDimension("time", None)
        nc.createDimension("node", len(st.verts))
        units, comment = cf_time_units(start)
        v = nc.createVariable("time", "f8", ("time",), fill_value=False)
        v.setncatts({"standard_name": "time", "long_name": "time of the snapshot",
                     "units": units, "calendar": "proleptic_gregorian", "axis": "T",
                     "comment": comment})
        v = nc.createVariable("step", "i4", ("time",), fill_value=FILL_INT)
        v.setncatts({"long_name": "step index of the snapshot; missing: an incomplete record",
                     "units": "1"})
        v = nc.createVariable("element", "i4", ("element",))
        v.setncatts({"cf_role": "trajectory_id", "long_name": "element index"})
        v[:] = np.arange(N, dtype=np.int32)

    def _define_records(self, ctx) -> None:
        """The per-snapshot variables ``(time, element)``: centroid lon/lat [degrees], velocity
        ``u, v`` [m/s], ``spin`` [rad/s] and the run's per-element fields; one contiguous block
        per variable and record."""
        self.fields = list(fields := ctx.element_fields())
        if cats := {np.shape(a)[1] for a in fields.values() if np.ndim(a) == 2}:
            self.nc.createDimension("category", cats.pop())  # thickness categories
        # the catalogue's (siku_core.fields): the centroid's position and motion, then the
        # engine's fields and those components declare (the run's own declarations)
        per = {k: (f.units, f.standard_name, f.long_name) for k, f in STATE_FIELDS.items()}
        declared, standard = ctx.field_catalogue(), ctx.standard_names()
        for k in self.fields:
            spec = ENGINE_FIELDS.get(k)
            u, ln = (spec.units, spec.long_name) if spec else ("1", f"per-element field '{k}'")
            if k in declared:  # declared by a component, or changed by processes
                u, ln = declared[k][:2]
            per[k] = (u, standard.get(k, ""), ln)
        for k, (u, std, ln) in per.items():
            dims = ("time", "element", "category")[:1 + max(1, np.ndim(fields.get(k, 0)))]
            if k == "flags":  # changed by processes (an element melted away)
                v = self.nc.createVariable(k, "i4", dims, fill_value=FILL_INT)
                v.setncatts(_flag_attrs())
            else:
                v = self.nc.createVariable(k, "f8", dims, fill_value=np.nan)
            v.setncatts({"units": u, "long_name": ln, **({"standard_name": std} if std else {})})
            if k in declared and declared[k][2] != "none":
                v.setncatts({"grid": declared[k][2]})
            if k not in ("lon", "lat"):
                v.setncatts({"coordinates": "time lat lon", "geometry": "outline"})

    def _define_geometry(self, ctx) -> None:
        """The fixed per-element values: area [m2], thickness [m], mass [kg], moment of inertia
        [kg m2], and the integer flags (with their meanings), material and floe."""
        from siku_io.output.layout import describe

        nc, st = self.nc, ctx.state
        geo = {"area": (st.area, "m2", "element area"),
               "thickness": (st.thickness, "m", "element thickness"),
               "mass": (st.m, "kg", "element mass"),
               "moment_of_inertia": (st.I, "kg m2", "polar moment of inertia about the "
                                     "centroid")}
        for k, (val, u, ln) in geo.items():
            if k in self.fields:  # changed by processes: a record variable instead
                continue
            v = nc.createVariable(k, "f8", ("element",))
            v.setncatts({"units": u, "long_name": ln})
            if k == "thickness":
                v.standard_name = "sea_ice_thickness"
            v[:] = val
        for k, val in (("flags", st.flags), ("material", st.material), ("floe", st.floe)):
            if k in self.fields:
                continue
            v = nc.createVariable(k, "i4", ("element",))
            units, ln = describe(f"geometry/{k}")
            v.setncatts({"units": units, "long_name": ln})
            if k == "flags":
                v.setncatts(_flag_attrs())
            v[:] = np.asarray(val).astype(np.int32)

    def _define_outlines(self, ctx) -> None:
        """The CF polygon geometry of the element outlines at the first time (vertex lon/lat
        [degrees]) and, with ``outlines``, the per-snapshot vertex variables."""
        from siku_core.geometry.element_geometry import polygons_lonlat

        nc, st = self.nc, ctx.state
        v = nc.createVariable("outline", "i4", ())
        v.setncatts({"geometry_type": "polygon", "node_count": "node_count",
                     "node_coordinates": "node_lon node_lat",
                     "long_name": "element outlines at the first time"})
        v = nc.createVariable("node_count", "i4", ("element",))
        v.long_name = "number of vertices of each element's polygon"
        v[:] = np.diff(st.vert_offsets).astype(np.int32)
        ll = polygons_lonlat(st.q, st.vert_offsets, st.verts, ctx.radius)
        flat = np.concatenate(ll) if ll else np.zeros((0, 2))
        for k, col, u, std, ax in (("node_lon", 0, "degrees_east", "longitude", "X"),
                                   ("node_lat", 1, "degrees_north", "latitude", "Y")):
            v = nc.createVariable(k, "f8", ("node",))
            v.setncatts({"units": u, "standard_name": std, "axis": ax,
                         "long_name": f"{std} of the polygon vertices at the first time"})
            v[:] = flat[:, col]
        if self.p["outlines"]:
            for k, u, ln in (("node_lon_t", "degrees_east", "longitude"),
                             ("node_lat_t", "degrees_north", "latitude")):
                v = nc.createVariable(k, "f8", ("time", "node"), fill_value=np.nan)
                v.setncatts({"units": u, "long_name": f"{ln} of the polygon vertices"})

    def write_state(self, ctx) -> None:
        from siku_core.geometry.quat import latlon_of
        from siku_core.geometry.element_geometry import east_north, polygons_lonlat

        if self._last == ctx.step_index or self.nc is None:
            return
        st = ctx.state
        t = self.t
        lat, lon = latlon_of(st.q)
        u, v = east_north(st.q, st.V)
        rows = {"lon": np.degrees(lon), "lat": np.degrees(lat), "u": u, "v": v, "spin": st.w}
        rows.update({k: np.asarray(a, np.int32 if k == "flags" else float)
                     for k, a in ctx.element_fields().items() if k in self.fields})
        if self.p["outlines"]:
            ll = polygons_lonlat(st.q, st.vert_offsets, st.verts, ctx.radius)
            flat = np.concatenate(ll) if ll else np.zeros((0, 2))
            rows["node_lon_t"], rows["node_lat_t"] = flat[:, 0], flat[:, 1]
        try:
            # time first (it grows the record: the other variables get missing values), step
            # last: a kill in between leaves a record with its time and missing values
            self.nc["time"][t] = ctx.time
            for k, a in rows.items():
                self.nc[k][t] = a
            self.nc.sync()
            self.nc["step"][t] = np.int32(ctx.step_index)
            self.nc.sync()
        except (OSError, RuntimeError) as exc:
            self._fail(exc, ctx)
        self.t += 1
        self._last = ctx.step_index
        if not self.published:
            from siku_core.run.outputs import publish

            publish(self.partial, self.target, replace=self.replace)
            self.published = True

    def write_diagnostics(self, ctx, diag) -> None:
        """Diagnostics are not part of this layout (the HDF5 writer keeps them)."""

    def _fail(self, exc, ctx):
        from siku_core.run.outputs import is_disk_full

        why = "disk full" if is_disk_full(exc) else f"write failed ({exc})"
        self._seal()
        self.nc = None
        if not self.published:
            self._discard()
            raise DataError(f"{self.target}: {why}; nothing written (an existing file is "
                            "untouched)") from None
        first = ctx.output_path
        if first is not None and Path(first).resolve() != self.target.resolve():
            how = (f"continue the run with --restart {first} once there is room: this file is "
                   "continued with it")
        else:  # the run's only file: kept, a new run goes to another file
            how = ("outputs of the NetCDF writer cannot be restarted: keep this file and run "
                   "the scene again to another --out, with [output] writer = \"hdf5\" and "
                   "this writer in [[output.extra]] to be able to restart")
        raise DataError(f"{self.target}: {why} at step {ctx.step_index}; the file holds "
                        f"{self.t} complete snapshots; {how}") from None

    def _seal(self) -> None:
        """Close the file after a failed write. When the library cannot close it, it has
        already freed the file's state, and freeing the Python object would close it a second
        time and crash the process: the object is kept alive (a reference the collector never
        takes back) until the process ends."""
        nc, self.nc = self.nc, None
        if nc is None:
            return
        try:
            nc.close()
        except Exception:  # noqa: BLE001 - the file is given up
            import ctypes

            _SEALED.append(nc)
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(nc))

    def _discard(self) -> None:
        self._seal()
        try:
            self.partial.unlink()
        except OSError:
            pass

    def close(self, ctx) -> None:
        from siku_core.run.outputs import settle

        if self.nc is not None:
            self._seal()
        settle(self)

    @classmethod
    def owns(cls, path) -> bool:
        from .marks import netcdf_kind

        return netcdf_kind(path) == "netcdf output"

    @classmethod
    def read_restart(cls, path, ctx) -> dict:
        raise DataError(f"{path}: outputs of the NetCDF writer cannot be restarted (they keep "
                        "no component history); a restart reads an HDF5 output ([output] "
                        "writer = \"hdf5\"): run the scene again")


@hookimpl
def siku_register_writers():
    return [NetCDFWriter]
