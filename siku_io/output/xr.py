"""siku output files as xarray datasets: ``xr.open_dataset("run.h5", engine="siku")``.

The backend (entry point ``siku`` of ``xarray.backends``) reads the complete snapshots of an
HDF5 output file (``siku_io.output.hdf5``; a file a killed run left behind opens too) or of a
Zarr output store (``siku_io.output.zarr_store``, read the same way) into a dataset
with dimensions ``time`` × ``element`` (and ``node``, the polygon vertices of all elements in
order):

* coordinates ``time`` (``datetime64`` when the scene has a start, else model seconds),
  ``step``, ``element``, ``lon``/``lat`` (time, element) of the centroids [degrees];
* ``u``/``v`` (time, element): eastward and northward velocity of the centroid [m/s],
  ``spin`` [rad/s], ``q`` (time, element, quaternion) and every per-element field of the file
  (with thickness categories ``category_fraction`` and ``category_thickness``: time, element,
  category)
  (``speed``, ``damage``, ``stress_ee``..., the fields components declare, with units, and
  their ``grid`` reduction: ``mean`` or ``sum``; under processes ``thickness``, ``mass`` and
  ``flags`` are among them, varying in time, in place of the fixed values);
* geometry per element: ``area``, ``thickness``, ``mass``, ``moment_of_inertia``, ``flags``
  (with CF ``flag_values``/``flag_meanings``), ``material``, ``floe``, ``node_count``;
* with ``outlines=True`` (default) the polygons: ``node_lon``/``node_lat`` (time, node)
  [degrees], element ``e`` owning nodes ``node_offset[e]`` to ``node_offset[e] +
  node_count[e]``; ``outlines_at(ds, t)`` turns them into a list of ``(k, 2)`` arrays;
* attributes: the file's root attributes, the scene text and the plugin versions.

``group="diagnostics"`` gives the diagnostics series (dimension ``time``), ``group="breaks"``
the joint breaks (dimension ``break``). The values are exactly those of the file.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from siku_core import DataError
from siku_core.fields import STATE_FIELDS, field_attrs
from siku_core.geometry.element_geometry import east_north, polygons_lonlat

GROUPS = (None, "states", "diagnostics", "breaks")


def _time_coord(time_s: np.ndarray, start: str, decode_times: bool):
    import xarray as xr

    if start and decode_times:
        t0 = np.datetime64(start.replace("+00:00", "").replace("Z", ""), "ns")
        vals = t0 + np.round(time_s * 1e9).astype("timedelta64[ns]")
        return xr.Variable("time", vals, {"long_name": "time of the snapshot", "axis": "T",
                                          "standard_name": "time"})
    attrs = {"long_name": "model time of the snapshot", "axis": "T"}
    attrs["units"] = f"seconds since {start}" if start else "s"
    return xr.Variable("time", time_s, attrs)


def _attrs(ds) -> dict:
    return {k: v for k, v in ds.attrs.items() if k in ("units", "long_name", "standard_name",
                                                      "flag_values", "flag_meanings", "grid")}


def open_output(path: str | os.PathLike, group: str | None = None, outlines: bool = True,
                decode_times: bool = True, drop_variables=None):
    """The complete snapshots of a siku HDF5 output file as an ``xarray.Dataset`` (module
    docstring); ``group``: ``None`` (the states), ``"diagnostics"`` or ``"breaks"``."""
    from siku_io.output.results import open_results

    path = Path(path)
    if group not in GROUPS:
        raise DataError(f"{path}: no group {group!r} in a siku output; one of states, "
                        "diagnostics, breaks")
    with open_results(path) as f:
        return dataset_of(f, path, group, outlines, decode_times, drop_variables)


def dataset_of(f, path: str | os.PathLike, group: str | None = None, outlines: bool = True,
               decode_times: bool = True, drop_variables=None,
               source: str | None = None):
    """:func:`open_output` of an open ``h5py.File`` ``f`` in siku's layout (a file, or the
    snapshots a run keeps in memory: ``Simulation.to_xarray``); ``path`` names it in messages
    and ``source`` says where it is (default: the file ``path``)."""
    import xarray as xr

    from siku_io.output.results import check_layout, n_snapshots

    path = Path(path)
    if group not in GROUPS:
        raise DataError(f"{path}: no group {group!r} in a siku output; one of states, "
                        "diagnostics, breaks")
    check_layout(f, path)
    root, attrs = _file_attrs(f, path)
    if source is not None:
        attrs["source"] = f"siku {root.get('siku_version', '')} {source}"
    start = str(root.get("start", ""))
    if group == "diagnostics":
        data, coords = _diagnostics_variables(f["diagnostics"], start, decode_times)
        return _drop(xr.Dataset(data, coords, attrs), drop_variables)
    if group == "breaks":
        if "breaks" not in f:
            return xr.Dataset(attrs=attrs)
        g = f["breaks"]
        n = int(g["time"].shape[0])
        data = {k: xr.Variable("break", ds[:n], _attrs(ds)) for k, ds in g.items()}
        return _drop(xr.Dataset(data, attrs=attrs), drop_variables)
    n = n_snapshots(f)
    s, geo = f["states"], f["geometry"]
    q = s["q"][:n]
    offsets = geo["vert_offsets"][...]
    # a field that changes (thickness, mass, flags under processes) replaces the fixed one
    data = {**_geometry_variables(geo, offsets), **_state_variables(s, q, n)}
    coords = _state_coords(s, n, int(root["n_elements"]), start, decode_times)
    if outlines:
        data.update(_outline_variables(q, offsets, geo["verts"][...], float(root["radius"])))
    return _drop(xr.Dataset(data, coords, attrs), drop_variables)


def _file_attrs(f, path: Path) -> tuple[dict, dict]:
    """The file's root attributes (decoded to Python values) and the dataset's attributes:
    those, the scene's text, the plugins' versions (JSON) and a ``source``."""
    root = {k: (v.item() if hasattr(v, "item") else v) for k, v in f.attrs.items()}
    root = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in root.items()}
    attrs = dict(root)
    attrs["scene"] = f["scene"][()].decode()
    attrs["plugins"] = json.dumps(dict(f["plugins"].attrs))
    attrs["source"] = f"siku {root.get('siku_version', '')} output file {path.name}"
    return root, attrs


def _diagnostics_variables(g, start: str, decode_times: bool) -> tuple[dict, dict]:
    """The diagnostics group's complete records: one variable per diagnostic along ``time``,
    and the ``time`` and ``step`` coordinates."""
    import xarray as xr

    n = int(g["step"].shape[0])
    data = {k: xr.Variable("time", ds[:n], _attrs(ds)) for k, ds in g.items()
            if k not in ("time", "step")}
    coords = {"time": _time_coord(g["time"][:n], start, decode_times),
              "step": xr.Variable("time", g["step"][:n], _attrs(g["step"]))}
    return data, coords


def _state_variables(s, q: np.ndarray, n: int) -> dict:
    """The first ``n`` snapshots of the states group ``s``: east and north velocity [m/s],
    spin [rad/s], quaternion ``q``, local velocity ``V`` and the per-element fields."""
    import xarray as xr

    V = s["V"][:n]
    u, v = east_north(q, V)
    te = ("time", "element")
    data = {
        "u": xr.Variable(te, u, field_attrs(STATE_FIELDS["u"])),  # the catalogue's
        "v": xr.Variable(te, v, field_attrs(STATE_FIELDS["v"])),
        "spin": xr.Variable(te, s["w"][:n], _attrs(s["w"])),
        "q": xr.Variable((*te, "quaternion"), q, _attrs(s["q"])),
        "V": xr.Variable((*te, "local_axis"), V, _attrs(s["V"])),
    }
    for name, ds in s.get("fields", {}).items():  # thickness categories: (..., category)
        data[name] = xr.Variable((*te, "category")[:ds.ndim], ds[:n], _attrs(ds))
    return data


def _geometry_variables(geo, offsets: np.ndarray) -> dict:
    """The fixed per-element values of the geometry group (area [m2], thickness [m], mass [kg],
    moment of inertia [kg m2], bounding radius, flags, material, floe) and each polygon's node
    count and first node."""
    import xarray as xr

    data = {}
    for name, key in (("area", "area"), ("thickness", "thickness"), ("mass", "m"),
                      ("moment_of_inertia", "I"), ("bounding_radius", "radius"),
                      ("flags", "flags"), ("material", "material"), ("floe", "floe")):
        data[name] = xr.Variable("element", geo[key][...], _attrs(geo[key]))
    data["node_count"] = xr.Variable("element", np.diff(offsets).astype(np.int32),
                                     {"long_name": "number of polygon vertices"})
    data["node_offset"] = xr.Variable("element", offsets[:-1].astype(np.int64),
                                      {"long_name": "index of the element's first node"})
    return data


def _state_coords(s, n: int, N: int, start: str, decode_times: bool) -> dict:
    """The coordinates of the states: ``time``, ``step``, ``element`` (``N`` elements) and the
    centroids' ``lon``, ``lat`` [degrees] of the first ``n`` snapshots."""
    import xarray as xr

    te = ("time", "element")
    return {
        "time": _time_coord(s["time"][:n], start, decode_times),
        "step": xr.Variable("time", s["step"][:n], _attrs(s["step"])),
        "element": xr.Variable("element", np.arange(N), {"long_name": "element index"}),
        "lon": xr.Variable(te, s["lon"][:n], {**_attrs(s["lon"]),
                                              "standard_name": "longitude"}),
        "lat": xr.Variable(te, s["lat"][:n], {**_attrs(s["lat"]),
                                              "standard_name": "latitude"}),
    }


def _outline_variables(q: np.ndarray, offsets: np.ndarray, verts: np.ndarray,
                       radius: float) -> dict:
    """The polygon vertices' lon/lat [degrees] ``(time, node)`` at every snapshot of ``q``, on
    the sphere of ``radius`` [m]."""
    import xarray as xr

    n = len(q)
    nl = np.empty((n, len(verts)))
    nt = np.empty((n, len(verts)))
    for t in range(n):
        ll = polygons_lonlat(q[t], offsets, verts, radius)
        flat = np.concatenate(ll) if ll else np.zeros((0, 2))
        nl[t], nt[t] = flat[:, 0], flat[:, 1]
    return {
        "node_lon": xr.Variable(("time", "node"), nl, {
            "units": "degrees_east", "long_name": "longitude of the polygon vertices"}),
        "node_lat": xr.Variable(("time", "node"), nt, {
            "units": "degrees_north", "long_name": "latitude of the polygon vertices"}),
    }


def _drop(ds, names):
    return ds.drop_vars([k for k in (names or ()) if k in ds.variables]) if names else ds


def outlines_at(ds, t=-1) -> list[np.ndarray]:
    """Polygons ``[lon, lat]`` (degrees, ``(k, 2)`` each) of every element at snapshot ``t``: an
    index (``-1``, the last) or a time (``ds.time[-1]``, ``"2001-04-06T12:00"``: the nearest
    snapshot)."""
    n = ds.sizes["time"]
    if hasattr(t, "values"):  # a DataArray such as ds.time[-1]
        t = t.values
    if not isinstance(t, (int, np.integer)):
        times = ds["time"].values
        try:
            want = np.atleast_1d(np.asarray(t).astype(times.dtype))
            t = int(ds.indexes["time"].get_indexer(want, method="nearest")[0])
        except (TypeError, ValueError) as exc:
            raise ValueError(f"outlines_at: {t!r} is neither a snapshot index nor a time like "
                             f"the dataset's ({times.dtype}): {exc}") from None
    if not -n <= t < n:
        raise IndexError(f"outlines_at: snapshot {t} is out of range: the dataset has {n} "
                         f"snapshots (0 to {n - 1}, or -1 for the last)")
    lon = ds["node_lon"].values[t]
    lat = ds["node_lat"].values[t]
    off = ds["node_offset"].values
    cnt = ds["node_count"].values
    return [np.column_stack([lon[o:o + c], lat[o:o + c]]) for o, c in zip(off, cnt)]


try:
    from xarray.backends import BackendEntrypoint
except ImportError:  # pragma: no cover - xarray is a dependency
    BackendEntrypoint = object


class SikuBackend(BackendEntrypoint):
    """``xr.open_dataset(path, engine="siku", group=None|"diagnostics"|"breaks",
    outlines=True)``: a siku HDF5 output file or Zarr output store (``siku_io.output.xr``)."""

    open_dataset_parameters = ("filename_or_obj", "drop_variables", "group", "outlines",
                               "decode_times")
    description = "Open siku sea-ice model output files (HDF5) in xarray"
    url = "https://github.com/siku-model/siku"

    def open_dataset(self, filename_or_obj, *, drop_variables=None, group=None, outlines=True,
                     decode_times=True):
        from siku_io.output.results import damaged

        with damaged(filename_or_obj):
            return open_output(filename_or_obj, group=group, outlines=outlines,
                               decode_times=decode_times, drop_variables=drop_variables)

    def guess_can_open(self, filename_or_obj) -> bool:
        from siku_io.output.marks import is_zarr_output

        try:
            if os.path.isdir(filename_or_obj):
                return is_zarr_output(filename_or_obj)
            import h5py

            with h5py.File(filename_or_obj, "r") as f:
                return "siku_version" in f.attrs
        except Exception:  # noqa: BLE001 - any file xarray asks about
            return False
