"""Initial ice cover from gridded data: ``[elements.mesh.cover]`` (the report's "automatic
import of initial ice coverage").

A CF NetCDF file gives the sea-ice concentration (area fraction, ``1`` or ``%``) and thickness
[m] on a lon/lat grid: 1-D ``lat``/``lon`` coordinates (a regular or Gaussian grid, sampled
bilinearly) or 2-D ones (a curvilinear grid such as a polar stereographic product, sampled at
the nearest grid point on the sphere). Names are mapped as for gridded winds (``concentration``,
``thickness``, ``lat``, ``lon``, ``time``); a variable with a time dimension is read at the
record nearest to ``[time] start``. Each ice cell of the mesh is sampled at its seed:

* concentration below ``threshold`` (or missing: land, fill values): open water, no element;
* otherwise an element of the field's thickness ``h`` (mass ``rho h A``).

Thickness categories (``category = "ncat"``, the report's thickness distribution ``g(h)``):
both variables carry a category dimension, the per-category area fraction ``a_k`` and thickness
``h_k``. The element's concentration is ``sum a_k``, its distribution ``g_k = a_k / sum a_k``
and its thickness the mean ``sum g_k h_k = sum a_k h_k / sum a_k``: the in-plane contact
stiffness, which adds over parallel layers (``E sum g_k h_k``), follows from that mean; its
mass counts only the ice, ``rho A sum a_k h_k`` (the concentration times that of a full cover
of the mean thickness: :func:`siku_core.categories.element_volume`). Without categories the
concentration only selects the cells: an element's ice covers it whole (mass ``rho h A``). The
element keeps its categories (``a_k``, ``h_k``: :mod:`siku_core.categories`), which processes
change and outputs carry; fractions that sum above 1, or a negative fraction or thickness, are
refused, naming the cell.

Missing values (NaN, or the file's own ``_FillValue``/``missing_value``, which the reader turns
into NaN) follow one rule: a missing concentration or category fraction is open water (no ice);
a missing thickness where there is ice (the cell is kept, or the category's fraction is
above 0) is refused in one line naming the file, the variable, the cell and the category.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from siku_core import DataError
from siku_forcing.gridded.cf import find_coordinate


@dataclass
class Cover:
    """The cover at a set of points: concentration [1], thickness [m] (NaN where the file has
    no thickness variable), and with categories the distribution ``g (n, K)``, category
    thicknesses ``h (n, K)`` and fractions ``a (n, K)``: a missing fraction is 0 (no ice of
    that category, its thickness then 0 m); a missing thickness of a category with ice is NaN,
    which the mesh source refuses."""

    concentration: np.ndarray
    thickness: np.ndarray
    g: np.ndarray | None = None
    h: np.ndarray | None = None
    a: np.ndarray | None = None


def _coord(ds, da, given: str, role: str, where: str):
    """The latitude or longitude (``role``) coordinate of ``da``: ``given``, or found by the CF
    rules of ``siku_forcing.gridded.cf`` among the variables along dimensions of ``da`` (1-D or
    2-D)."""
    if given:
        if given not in ds.variables:
            raise DataError(f"{where}: no coordinate '{given}' ({role}) in the file")
        return ds[given]
    dims = set(da.dims)
    found = find_coordinate(((k, v) for k, v in ds.variables.items() if set(v.dims) <= dims),
                            role[:3])
    if found is not None:
        return ds[found]
    raise DataError(f"{where}: cannot tell the {role} of the variable '{da.name}'; set "
                    f"{role[:3]} = \"...\" in [elements.mesh.cover]")


def _pick_time(da, tname: str, start, where: str):
    tdims = [d for d in da.dims if d == tname or (not tname and (
        np.issubdtype(da[d].dtype, np.datetime64) if d in da.coords else False))]
    if not tdims:
        return da
    d = tdims[0]
    if da.sizes[d] == 1:
        return da.isel({d: 0})
    if start is None:
        raise DataError(f"{where}: '{da.name}' has {da.sizes[d]} time records; give [time] "
                        "start to pick the one nearest to it")
    t = da[d].values.astype("datetime64[s]")
    t0 = np.datetime64(start.replace(tzinfo=None).isoformat(), "s")
    return da.isel({d: int(np.argmin(np.abs(t - t0)))})


def _sample(values: np.ndarray, lat, lon, plat: np.ndarray, plon: np.ndarray) -> np.ndarray:
    """``values (..., ny, nx)`` on the grid at the points (bilinear on 1-D coordinates, nearest
    on 2-D ones); points outside the grid get NaN."""
    lead = values.shape[:-2]
    flat = values.reshape(-1, *values.shape[-2:])
    if lat.ndim == 1:
        from scipy.interpolate import RegularGridInterpolator

        order = np.argsort(lat)
        la = lat[order]
        lo_ref = float(np.mean(plon)) if len(plon) else 0.0
        lo = (lon - lo_ref + 180.0) % 360.0 - 180.0 + lo_ref  # unwrap around the points
        lorder = np.argsort(lo)
        lo = lo[lorder]
        px = (plon - lo_ref + 180.0) % 360.0 - 180.0 + lo_ref
        out = np.empty((len(flat), len(plat)))
        for k, v in enumerate(flat):
            f = RegularGridInterpolator((la, lo), v[np.ix_(order, lorder)],
                                        bounds_error=False, fill_value=np.nan)
            out[k] = f(np.column_stack([plat, px]))
    else:
        from scipy.spatial import cKDTree

        from siku_core.geometry.sphere import lonlat_to_xyz

        ok = np.isfinite(lat) & np.isfinite(lon)
        tree = cKDTree(lonlat_to_xyz(lon[ok], lat[ok]))
        _, nearest = tree.query(lonlat_to_xyz(plon, plat))
        out = np.stack([v[ok][nearest] for v in flat])
    return out.reshape(*lead, len(plat))


def read_cover(cfg, base_dir: Path, start, plon: np.ndarray, plat: np.ndarray,
               where: str) -> Cover:
    """The cover of ``[elements.mesh.cover]`` ``cfg`` at points ``plon, plat`` [deg]."""
    import xarray as xr

    path = base_dir / cfg.file
    if not path.is_file():
        raise DataError(f"{where}: ice cover file {path} not found")
    try:
        ds = xr.open_dataset(path, engine="netcdf4", decode_timedelta=False)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
        raise DataError(f"{where}: cannot read {path} as NetCDF: {exc}") from None
    with ds:
        fields = {}
        for role, var in (("concentration", cfg.concentration), ("thickness", cfg.thickness)):
            if not var:
                continue
            if var not in ds.variables:
                raise DataError(f"{where}: {path} has no variable '{var}' ({role}); variables "
                                f"present: {', '.join(sorted(map(str, ds.data_vars)))}")
            da = _pick_time(ds[var], cfg.time, start, where)
            lat = _coord(ds, da, cfg.lat, "latitude", where)
            lon = _coord(ds, da, cfg.lon, "longitude", where)
            cat = cfg.category
            if cat and cat not in da.dims:
                raise DataError(f"{where}: '{var}' has no category dimension '{cat}' (its "
                                f"dimensions: {', '.join(map(str, da.dims))})")
            spatial = [d for d in da.dims if d in lat.dims or d in lon.dims]
            if lat.ndim == 1:
                spatial = [lat.dims[0], lon.dims[0]]
            extra = [d for d in da.dims if d not in spatial and d != cat]
            if extra:
                raise DataError(f"{where}: '{var}' has dimensions {', '.join(extra)} besides "
                                "the grid" + ("" if cat else
                                              " (thickness categories? set category = "
                                              f"\"{extra[0]}\")"))
            da = da.transpose(*([cat] if cat else []), *spatial)
            units = str(da.attrs.get("units", "1")).strip()
            vals = np.asarray(da.values, dtype=float)
            if role == "concentration" and units in ("%", "percent"):
                vals = vals / 100.0
            if role == "thickness" and units not in ("m", "meters", "metre", "metres", "meter"):
                raise DataError(f"{where}: '{var}' has units '{units}'; expected metres (m)")
            la = np.asarray(lat.values, dtype=float)
            lo = np.asarray(lon.values, dtype=float)
            if la.ndim == 2 and lat.dims != tuple(spatial):
                la, lo = la.T, lo.T
            fields[role] = _sample(vals, la, lo, plat, plon)
    conc = fields["concentration"]
    thick = fields.get("thickness")
    if not cfg.category:
        h = thick if thick is not None else np.full(len(plat), np.nan)
        return Cover(np.where(np.isfinite(conc), conc, 0.0), h)
    from siku_core.categories import category_mean

    a = np.where(np.isfinite(conc), conc, 0.0)  # (K, n); checked by the mesh source
    if thick is None:
        raise DataError(f"{where}: thickness categories need a thickness variable")
    total = a.sum(axis=0)
    g = np.divide(a, total, out=np.zeros_like(a), where=total > 0)
    # a category's thickness counts only where it has ice: missing there stays NaN (refused
    # by the mesh source, naming the cell and category); where a_k = 0 it is no ice: 0 m
    hk = np.where(a > 0, thick, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = category_mean(a.T, hk.T)
    return Cover(total, np.where(total > 0, mean, np.nan), g.T, hk.T, a.T)
