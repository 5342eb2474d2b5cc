"""Element results on a regular grid (``siku grid``, ``[output.grid]``): concentration,
thickness, velocity, strain rates, stress and broken joints per cell, as a CF-NetCDF dataset.

Per cell, at each gridded time (``siku_forcing.gridded.regular_grid`` gives the overlap ``fraction``
of
each element with each cell and the cell's true area ``A_c``):

* ``concentration`` = sum of ``fraction × area`` over the elements / ``A_c`` [1] (CF
  ``sea_ice_area_fraction``; overlapping elements may push it above 1, except where the
  ``ridging`` process has taken the overlap from the giver's ice); with thickness categories
  each element counts its ice, ``sum a_k`` of its area, and its open water lies first where
  its footprint overlaps other elements' (where the ice it ceded went), only the rest spread
  over its footprint (``Grid.overlap`` with ``cover``), so a cell narrower than an element
  is not counted twice under a ridge;
* ``thickness`` = ice volume / ``A_c`` [m] (the mean thickness of the whole cell; an element's
  volume is ``area × thickness``, with categories ``area × sum a_k h_k``, placed with its ice:
  ``siku_core.categories.element_volume``);
* ``u``, ``v``: mass-weighted mean velocity [m/s], east/north on a lonlat grid, along the grid
  axes on a polar stereographic one;
* strain rates [1/s] from the element centres inside the cell by the line integral around their
  convex hull, as for RGPS cells (Kwok et al. 2008): ``du/dx = (1/A) ∮ u dy``, ``du/dy = -(1/A)
  ∮ u dx`` (likewise ``v``), the trapezoidal rule along each hull edge, which is exact for any
  velocity field linear in position. Then ``divergence = ux + vy``, ``shear = sqrt((ux -
  vy)² + (uy + vx)²)``, ``vorticity = vx - uy``, ``total_deformation = sqrt(divergence² +
  shear²)``. A cell with fewer than ``min_elements`` centres, or whose hull covers less than
  ``min_hull`` of it, gets NaN. Positions are in the grid's plane: projected metres on a polar
  stereographic grid (as RGPS), the equirectangular plane about the cell centre on a lonlat one;
* stress [N/m]: the area-weighted mean of the element stresses (``siku_core.contact.stress``) in
  grid
  components ``stress_xx``, ``stress_yy``, ``stress_xy``, principal stresses ``stress_1 >=
  stress_2``, ``stress_I = (s1 + s2)/2`` (mean normal stress) and ``stress_II = (s1 - s2)/2``
  (maximum shear stress); NaN where a cell holds no ice;
* ``broken_joints``: joints broken by then whose midpoint (between the centres of their two
  elements) lies in the cell [1], the open leads the joints record;
* floe sizes (``siku_io.analysis.fsd``, the floes over each snapshot's intact joints):
  ``floe_number`` (the floes in the cell, each element counting its share of the cell times its
  area over its floe's), ``floe_area_mean`` [m²] and ``floe_caliper_mean`` [m] (of the floe the
  ice in the cell belongs to, weighted by that ice's area);
* with thickness categories (``siku_core.categories``: fractions ``a_k``, thicknesses ``h_k``
  per element), along a ``category`` dimension: ``category_fraction`` = sum of ``fraction ×
  area × a_k`` / sum of ``fraction × area`` [1] (the mean fraction of category ``k`` over the
  ice in the cell, weighted by its area; NaN without ice) and ``category_thickness`` = sum of
  ``fraction × area × a_k h_k`` / sum of ``fraction × area × a_k`` [m] (the mean thickness of
  the category's ice in the cell; NaN where the category has none).

Leads (linear kinematic features) found on these fields (``siku_io.analysis.leads``) go into the
same file as tables along the dimensions ``lead`` and ``intersection``.
"""
from __future__ import annotations

import numpy as np

from siku_core import DataError
from siku_core.categories import Categories, ice_per_area
from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat
from siku_core.contact.stress import principal
from siku_io.analysis import fsd
from siku_forcing.gridded.regular_grid import Grid, GridCfg, cell_means

#: gridded fields: name -> (units, standard name or "", long name)
GRID_FIELDS: dict[str, tuple[str, str, str]] = {
    "concentration": ("1", "sea_ice_area_fraction", "ice area over cell area"),
    "thickness": ("m", "sea_ice_thickness", ("ice volume over cell area (mean thickness of the "
                                             "whole cell)")),
    "u": ("m s-1", "", "mass-weighted mean ice velocity along x (east on a lonlat grid)"),
    "v": ("m s-1", "", "mass-weighted mean ice velocity along y (north on a lonlat grid)"),
    "divergence": ("s-1", "divergence_of_sea_ice_velocity", "divergence ux + vy"),
    "shear": ("s-1", "", "maximum shear strain rate sqrt((ux - vy)^2 + (uy + vx)^2)"),
    "vorticity": ("s-1", "", "vorticity vx - uy"),
    "total_deformation": ("s-1", "", "total deformation rate sqrt(divergence^2 + shear^2)"),
    "stress_xx": ("N m-1", "", ("mean stress of the ice in the cell, xx (tension positive), "
                                "vertically integrated")),
    "stress_yy": ("N m-1", "", "mean stress, yy (tension positive), vertically integrated"),
    "stress_xy": ("N m-1", "", "mean stress, xy, vertically integrated"),
    "stress_1": ("N m-1", "", "larger principal stress, vertically integrated"),
    "stress_2": ("N m-1", "", "smaller principal stress, vertically integrated"),
    "stress_I": ("N m-1", "", "mean normal stress (stress_1 + stress_2)/2"),
    "stress_II": ("N m-1", "", "maximum shear stress (stress_1 - stress_2)/2"),
    "n_elements": ("1", "", "element centres in the cell"),
    "broken_joints": ("1", "", "broken joints with their midpoint in the cell"),
}
#: the floe fields of ``siku fsd`` (:data:`GRID_FSD`): floes over the intact
#: joints of each snapshot
FLOE_FIELDS = ("floe_number", "floe_area_mean", "floe_caliper_mean")

#: gridded thickness categories, dimensions (time, category, y, x): name -> (units, standard
#: name or "", long name)
CATEGORY_GRID_FIELDS: dict[str, tuple[str, str, str]] = {
    "category_fraction": ("1", "", "mean area fraction of each thickness category over the "
                          "ice in the cell (weighted by the ice area)"),
    "category_thickness": ("m", "", "mean ice thickness of each thickness category in the "
                           "cell (weighted by the category's ice area)"),
}


def strain_rates(x, y, u, v) -> tuple[float, float, float, float, float]:
    """Velocity gradient ``(ux, uy, vx, vy)`` [1/s] and hull area [m²] of points ``(x, y)``
    [m] with velocities ``(u, v)`` [m/s]: the line integral around their convex hull
    (module docstring). NaN gradient for fewer than 3 points or a degenerate hull."""
    from scipy.spatial import ConvexHull, QhullError

    nan = (np.nan, np.nan, np.nan, np.nan, 0.0)
    if len(x) < 3:
        return nan
    pts = np.column_stack([x, y])
    try:
        hull = ConvexHull(pts)
    except QhullError:
        return nan
    k = hull.vertices  # counter-clockwise in 2-D
    xs, ys, us, vs = x[k], y[k], u[k], v[k]
    xn, yn, un, vn = (np.roll(a, -1) for a in (xs, ys, us, vs))
    area = 0.5 * np.sum(xs * yn - xn * ys)
    if not area > 0.0:
        return nan
    dx, dy = xn - xs, yn - ys
    um, vm = 0.5 * (us + un), 0.5 * (vs + vn)
    return (np.sum(um * dy) / area, -np.sum(um * dx) / area, np.sum(vm * dy) / area,
            -np.sum(vm * dx) / area, area)


class Snapshot:
    """What the gridding needs of one state: per element ``lon``, ``lat`` [deg] of the centre,
    ``u``, ``v`` [m/s] east/north, ``area`` [m²], ``thickness`` [m], ``mass`` [kg], stress
    east/north components [N/m] (``stress``: ``(N, 3)`` or ``None``), the polygons
    (``node_lon``, ``node_lat`` [deg], CSR ``offsets``), broken joints ``(i, j)`` and the
    per-element fields components declared (``extra``: name -> (values, reduction)) and the
    thickness categories (``categories``: fractions and thicknesses ``(N, K)``, or ``None``)."""

    def __init__(self, lon, lat, u, v, area, thickness, mass, node_lon, node_lat, offsets,
                 stress=None, broken=None, extra=None, categories=None):
        self.lon, self.lat = np.asarray(lon, float), np.asarray(lat, float)
        self.u, self.v = np.asarray(u, float), np.asarray(v, float)
        self.area, self.thickness = np.asarray(area, float), np.asarray(thickness, float)
        self.mass = np.asarray(mass, float)
        self.node_lon, self.node_lat = np.asarray(node_lon, float), np.asarray(node_lat, float)
        self.offsets = np.asarray(offsets, np.int64)
        self.stress = None if stress is None else np.asarray(stress, float)
        self.broken = np.zeros((0, 2), np.int64) if broken is None else np.asarray(broken)
        #: declared per-element fields to grid: name -> (values, "mean" or "sum")
        self.extra = extra or {}
        self.categories = None if categories is None else tuple(
            np.asarray(x, float) for x in categories)


def snapshot_of(sim) -> Snapshot:
    """The :class:`Snapshot` of a running simulation's current state (its stress: that of the
    last force evaluation)."""
    from siku_core.geometry.quat import latlon_of
    from siku_core.geometry.element_geometry import east_north, polygons_lonlat

    st = sim.state
    lat, lon = latlon_of(st.q)
    u, v = east_north(st.q, st.V)
    ll = polygons_lonlat(st.q, st.vert_offsets, st.verts, sim.radius)
    nodes = np.concatenate(ll) if ll else np.zeros((0, 2))
    fields = sim.element_fields()
    stress = None
    if "stress_ee" in fields:
        stress = np.column_stack([fields[k] for k in ("stress_ee", "stress_nn", "stress_en")])
    broken = None
    cm = sim.context.contacts
    if cm is not None and cm.n_joints:
        b = ~cm.intact
        broken = np.column_stack([cm.ji[b], cm.jj[b]])
    cat = sim.context.field_catalogue()
    extra = {k: (np.asarray(fields[k], float), g) for k, (_, _, g) in cat.items()
             if g in ("mean", "sum")}
    cats = sim.context.categories
    return Snapshot(np.degrees(lon), np.degrees(lat), u, v, st.area, st.thickness, st.m,
                    nodes[:, 0], nodes[:, 1], st.vert_offsets, stress, broken, extra,
                    None if cats is None else (cats.fraction, cats.thickness))


def grid_snapshot(grid: Grid, snap: Snapshot) -> dict[str, np.ndarray]:
    """Every field of :data:`GRID_FIELDS` on ``grid`` for one state, ``(ny, nx)`` arrays."""
    ny, nx = grid.shape
    nc = ny * nx
    A = grid.cell_area.ravel()
    # with categories an element's open water lies first where its footprint overlaps
    # another's (Grid.overlap's ice shares)
    cover = None if snap.categories is None else Categories(*snap.categories).fraction.sum(1)
    el, cell, frac, *fice = grid.overlap(snap.node_lon, snap.node_lat, snap.offsets, snap.lon,
                                         cover)
    w = frac * snap.area[el]
    ice = np.bincount(cell, w, nc)
    if snap.categories is None:
        out = {"concentration": ice / A,
               "thickness": np.bincount(cell, w * snap.thickness[el], nc) / A}
    else:  # the ice of an element covers sum a_k of it; its volume is A sum a_k h_k
        cats = Categories(*snap.categories)
        wi = fice[0] * snap.area[el]
        h_ice = np.divide(ice_per_area(snap.thickness, cats), cover,
                          out=np.zeros(len(cover)), where=cover > 0.0)
        out = {"concentration": np.bincount(cell, wi, nc) / A,
               "thickness": np.bincount(cell, wi * h_ice[el], nc) / A}
    gu, gv = grid.rotate(snap.u, snap.v, snap.lon)
    wm = frac * snap.mass[el]
    msum = np.bincount(cell, wm, nc)
    out["u"] = cell_means(cell, wm, msum, gu[el], np.nan)
    out["v"] = cell_means(cell, wm, msum, gv[el], np.nan)
    # strain rates from the centres inside each cell
    X, Y = grid.to_plane(snap.lon, snap.lat)
    ix = np.searchsorted(grid.x_edges, X, side="right") - 1
    iy = np.searchsorted(grid.y_edges, Y, side="right") - 1
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    home = np.where(inside, iy * nx + ix, -1)
    out["n_elements"] = np.bincount(home[inside], minlength=nc).astype(float)
    grad = np.full((4, nc), np.nan)
    cfg = grid.cfg
    order = np.argsort(home, kind="stable")
    bounds = np.searchsorted(home[order], np.arange(nc + 1))
    for c in np.flatnonzero(out["n_elements"] >= cfg.min_elements):
        members = order[bounds[c]:bounds[c + 1]]
        px, py = grid.local_metres(snap.lon[members], snap.lat[members], c // nx, c % nx)
        ux, uy, vx, vy, hull = strain_rates(px, py, gu[members], gv[members])
        if hull >= cfg.min_hull * A[c]:
            grad[:, c] = ux, uy, vx, vy
    ux, uy, vx, vy = grad
    out["divergence"] = ux + vy
    out["shear"] = np.hypot(ux - vy, uy + vx)
    out["vorticity"] = vx - uy
    out["total_deformation"] = np.hypot(out["divergence"], out["shear"])
    if snap.stress is not None:
        a = grid.axes(snap.lon, snap.lat)
        ca, sa = np.cos(a), np.sin(a)
        see, snn, sen = snap.stress.T
        # Q sigma Q^T with Q = [[cos a, sin a], [-sin a, cos a]]: east/north to grid axes
        sxx = ca * ca * see + 2 * ca * sa * sen + sa * sa * snn
        syy = sa * sa * see - 2 * ca * sa * sen + ca * ca * snn
        sxy = (ca * ca - sa * sa) * sen + ca * sa * (snn - see)
        for name, s in (("stress_xx", sxx), ("stress_yy", syy), ("stress_xy", sxy)):
            out[name] = cell_means(cell, w, ice, s[el], np.nan)
        s1, s2, sI, sII = principal(out["stress_xx"], out["stress_yy"], out["stress_xy"])
        out.update(stress_1=s1, stress_2=s2, stress_I=sI, stress_II=sII)
    if len(snap.broken):
        i, j = snap.broken[:, 0], snap.broken[:, 1]
        mid = _midpoints(snap.lon[i], snap.lat[i], snap.lon[j], snap.lat[j])
        bx, by = grid.to_plane(*mid)
        bi = np.searchsorted(grid.x_edges, bx, side="right") - 1
        bj = np.searchsorted(grid.y_edges, by, side="right") - 1
        ok = (bi >= 0) & (bi < nx) & (bj >= 0) & (bj < ny)
        out["broken_joints"] = np.bincount(bj[ok] * nx + bi[ok], minlength=nc).astype(float)
    else:
        out["broken_joints"] = np.zeros(nc)
    for name, (values, how) in snap.extra.items():
        if how == "sum":  # extensive: each element's share in the cell
            out[name] = np.bincount(cell, frac * values[el], nc)
        else:  # intensive: the mean over the ice in the cell, weighted by its area
            out[name] = cell_means(cell, w, ice, values[el], np.nan)
    if snap.categories is not None:
        out.update(_categories(cell, w, ice, el, snap.categories, nc))
    return {k: v.reshape(*v.shape[:-1], ny, nx) for k, v in out.items()}


def _categories(cell, w, ice, el, categories, nc: int) -> dict[str, np.ndarray]:
    """``category_fraction`` and ``category_thickness`` ``(K, nc)`` (module docstring) from the
    element-cell overlaps (``cell``, their ice area ``w``, the elements ``el``, the cells' ice
    area ``ice``) and the elements' fractions and thicknesses ``(N, K)``."""
    a, h = categories
    K = a.shape[1]
    frac, thick = np.full((K, nc), np.nan), np.full((K, nc), np.nan)
    for k in range(K):
        wa = w * a[el, k]
        area_k = np.bincount(cell, wa, nc)
        frac[k] = cell_means(cell, w, ice, a[el, k], np.nan)
        thick[k] = cell_means(cell, wa, area_k, h[el, k], np.nan)
    return {"category_fraction": frac, "category_thickness": thick}


def _midpoints(lon1, lat1, lon2, lat2):
    """Great-circle midpoints [deg] of point pairs [deg]."""
    return xyz_to_lonlat(lonlat_to_xyz(lon1, lat1) + lonlat_to_xyz(lon2, lat2))


# ---------------------------------------------------------------------------- from a file
def snapshots(ds, breaks=None):
    """:class:`Snapshot` of every time of an output dataset (``siku_io.output.xr.open_output``),
    with the breaks dataset (``group="breaks"``) for the broken joints."""
    off = np.r_[ds["node_offset"].values, ds.sizes["node"]]
    stress = all(k in ds for k in ("stress_ee", "stress_nn", "stress_en"))
    bt = bi = bj = None
    if breaks is not None and "time" in breaks:
        bt, bi, bj = (breaks[k].values for k in ("time", "i", "j"))
    seconds = snapshot_seconds(ds)
    extra = declared_in(ds)
    cats = None
    if "category_fraction" in ds and "category_thickness" in ds:
        cats = [ds[k].transpose("time", "element", "category").values
                for k in ("category_fraction", "category_thickness")]
    for t in range(ds.sizes["time"]):
        broken = None
        if bt is not None:
            done = bt <= seconds[t]
            broken = np.column_stack([bi[done], bj[done]])
        yield Snapshot(
            ds["lon"].values[t], ds["lat"].values[t], ds["u"].values[t], ds["v"].values[t],
            ds["area"].values, _at(ds["thickness"], t), _at(ds["mass"], t),
            ds["node_lon"].values[t], ds["node_lat"].values[t], off,
            np.column_stack([ds[k].values[t] for k in ("stress_ee", "stress_nn", "stress_en")])
            if stress else None, broken,
            {k: (ds[k].values[t].astype(float), how) for k, how in extra.items()},
            None if cats is None else (cats[0][t], cats[1][t]))


def _at(var, t: int) -> np.ndarray:
    """A per-element variable at snapshot ``t``: fixed, or changing in time (processes)."""
    return var.values[t] if "time" in var.dims else var.values


def declared_in(ds) -> dict[str, str]:
    """The per-element fields of an output dataset that components declared to be gridded:
    name -> ``mean`` or ``sum`` (their ``grid`` attribute)."""
    return {k: str(v.attrs["grid"]) for k, v in ds.data_vars.items()
            if v.attrs.get("grid") in ("mean", "sum") and v.dims == ("time", "element")}


def snapshot_seconds(ds) -> np.ndarray:
    """Model seconds of every snapshot of an output dataset."""
    t = ds["time"].values
    if np.issubdtype(t.dtype, np.datetime64):
        t0 = np.datetime64(str(ds.attrs["start"]).replace("+00:00", "").replace("Z", ""), "ns")
        return (t - t0) / np.timedelta64(1, "s")
    return np.asarray(t, dtype=float)


def grid_output(path, cfg: GridCfg, progress: bool = False):
    """The gridded dataset (``xarray.Dataset``, CF) of an output file at every snapshot (or
    every ``cfg.every``), with its leads (``siku_io.analysis.leads``)."""
    from siku_core.scene.units import parse_duration
    from siku_io.output.xr import open_output

    ds = open_output(path)
    breaks = open_output(path, group="breaks")
    grid = Grid(cfg, float(ds.attrs["radius"]))
    seconds = snapshot_seconds(ds)
    keep = np.arange(ds.sizes["time"])
    if cfg.every is not None:
        try:
            every = parse_duration(cfg.every) if isinstance(cfg.every, str) else float(cfg.every)
        except ValueError as exc:
            raise DataError(f"[output.grid] every = {cfg.every!r}: {exc}") from None
        marks = np.floor(seconds / every + 1e-9)
        keep = np.flatnonzero(np.r_[True, np.diff(marks) > 0])
    ds = ds.isel(time=keep)
    rows = []
    snaps = snapshots(ds, breaks)
    floes = None
    if cfg.fields is None or set(FLOE_FIELDS) & set(cfg.fields):
        from siku_core.errors import SikuError

        try:  # the floes need the run's joints: its scene is built again (siku fsd)
            floes = fsd.output_floes(path, calipers=cfg.fields is None
                                 or "floe_caliper_mean" in cfg.fields)
        except SikuError as exc:
            if cfg.fields is not None:  # asked for by name: refused, one line
                raise
            import sys

            print(f"{path}: no floe sizes on the grid ({exc})", file=sys.stderr)
    if progress:
        from tqdm import tqdm

        snaps = tqdm(snaps, total=ds.sizes["time"], desc="gridding", unit="snapshot")
    ny, nx = grid.shape
    for i, snap in enumerate(snaps):
        rows.append(grid_snapshot(grid, snap))
        if floes is not None:
            cells = floe_cells(grid, snap, floes[keep[i]])
            rows[-1].update({k: v.reshape(ny, nx) for k, v in cells.items()})
    return to_dataset(grid, rows, ds, cfg)


def to_dataset(grid: Grid, rows: list[dict], src, cfg: GridCfg):
    """CF dataset of gridded rows (one dict per time) with the coordinates of ``src`` (an
    output dataset) and the leads tables."""
    import xarray as xr

    from siku_io.analysis.leads import detect_series

    declared = {k: (str(src[k].attrs.get("units", "1")), "",
                    f"{src[k].attrs.get('long_name', k)} ({src[k].attrs['grid']} over the "
                    "elements in the cell)")
                for k in declared_in(src)}
    known = {**GRID_FIELDS, **{k: (GRID_FSD[k][0], "", GRID_FSD[k][1]) for k in FLOE_FIELDS},
             **declared}
    if rows and "category_fraction" in rows[0]:
        known.update(CATEGORY_GRID_FIELDS)
    names = [k for k in known if rows and k in rows[0] and (cfg.fields is None
                                                            or k in cfg.fields)]
    if cfg.fields:
        unknown = sorted(set(cfg.fields) - set(known))
        if unknown:
            raise DataError(f"[output.grid] fields: unknown {', '.join(unknown)}; known: "
                            f"{', '.join(known)}")
    dims = ("time", *grid.dims)
    from siku_io.output.netcdf import cf_time_units

    coords = {k: xr.Variable(d, v, a) for k, (d, v, a) in grid.cf_coords().items()}
    units, comment = cf_time_units(str(src.attrs.get("start", "")))
    coords["time"] = xr.Variable("time", snapshot_seconds(src), {
        "standard_name": "time", "long_name": "time of the gridded fields", "units": units,
        "calendar": "proleptic_gregorian", "axis": "T", "comment": comment})
    mapping = "crs" if grid.kind != "lonlat" else None
    data = {}
    for k in names:
        units, std, long_name = known[k]
        attrs = {"units": units, "long_name": long_name}
        if std:
            attrs["standard_name"] = std
        if k in ("u", "v"):
            if grid.kind == "lonlat":
                attrs["standard_name"] = ("eastward_sea_ice_velocity" if k == "u" else
                                          "northward_sea_ice_velocity")
            else:
                attrs["standard_name"] = "sea_ice_x_velocity" if k == "u" else \
                    "sea_ice_y_velocity"
        if mapping:
            attrs["grid_mapping"] = mapping
            attrs["coordinates"] = "lat lon"
        attrs["cell_measures"] = "area: cell_area"
        dk = dims if k not in CATEGORY_GRID_FIELDS else ("time", "category", *grid.dims)
        data[k] = xr.Variable(dk, np.stack([r[k] for r in rows]) if rows else
                              np.zeros((0, *grid.shape)), attrs)
    data["cell_area"] = xr.Variable(grid.dims, grid.cell_area, {
        "units": "m2", "standard_name": "cell_area", "long_name": "true area of the cell on "
        "the model sphere", **({"grid_mapping": mapping, "coordinates": "lat lon"}
                               if mapping else {})})
    out = xr.Dataset(data, coords)
    if cfg.leads and rows:
        out = out.merge(detect_series(grid, out, cfg))
    out.attrs.update({
        "Conventions": "CF-1.8",
        "title": f"{src.attrs.get('title', '')}: gridded fields".strip(": "),
        "source": f"siku {src.attrs.get('siku_version', '')} (siku grid)",
        "history": f"gridded from {src.attrs.get('source', 'a siku output file')}",
        "grid": cfg.model_dump_json(exclude_none=True),
        "start": str(src.attrs.get("start", "")),
        "earth_radius": float(grid.radius),
        "scene": src.attrs.get("scene", ""),
        "references": "Kwok et al. (2008), J. Geophys. Res. 113, C08010 (RGPS strain rates)",
    })
    return out


# ------------------------------------------------------------------------ floe sizes on a grid
#: gridded floe fields: name -> (units, long name)
GRID_FSD = {
    "concentration": ("1", "ice area over cell area"),
    "floe_number": ("1", "floes in the cell: sum over its elements of their share of the cell "
                    "times their area over their floe's area"),
    "floe_area_mean": ("m2", "area of the floe the ice in the cell belongs to, mean weighted by "
                       "that ice's area"),
    "floe_caliper_mean": ("m", "mean caliper diameter of the floe the ice in the cell belongs "
                          "to, mean weighted by that ice's area"),
}


def grid_distribution(path, cfg):
    """Floe sizes per cell of the regular grid ``cfg`` (``siku_forcing.gridded.regular_grid``,
    the same overlap of elements and cells as ``siku grid``) at every snapshot of output file
    ``path``: :data:`GRID_FSD` as an ``xarray.Dataset`` along ``time`` and the grid's two
    dimensions."""
    import xarray as xr

    from siku_forcing.gridded.regular_grid import Grid
    from siku_io.output.xr import open_output

    fl = fsd.output_floes(path)
    ds = open_output(path)
    grid = Grid(cfg, float(ds.attrs["radius"]))
    ny, nx = grid.shape
    rows = [floe_cells(grid, snap, f, with_concentration=True)
            for snap, f in zip(snapshots(ds, open_output(path, group="breaks")), fl)]
    dims = ("time", *grid.dims)
    coords = {k: xr.Variable(d, v, a) for k, (d, v, a) in grid.cf_coords().items()}
    coords["time"] = xr.Variable("time", [f.time for f in fl], {
        "units": "s", "long_name": "model time of the snapshot"})
    data = {k: xr.Variable(dims, np.stack([r[k].reshape(ny, nx) for r in rows]),
                           {"units": u, "long_name": n}) for k, (u, n) in GRID_FSD.items()}
    out = xr.Dataset(data, coords)
    out.attrs.update({"title": "floe size distribution per cell",
                      "grid": cfg.model_dump_json(exclude_none=True)})
    return out


def floe_cells(grid, snap, floes: fsd.Floes, with_concentration: bool = False) -> dict:
    """The floe fields of :data:`GRID_FSD` per cell (flat arrays) of one snapshot ``snap``
    (:class:`Snapshot`) whose floes are ``floes``; the
    concentration too if asked."""
    nc = grid.shape[0] * grid.shape[1]
    el, cell, frac = grid.overlap(snap.node_lon, snap.node_lat, snap.offsets, snap.lon)
    w = frac * snap.area[el]
    ice = np.bincount(cell, w, nc)
    floe_a = floes.area[floes.label][el]
    # (float even where no element reaches the grid: bincount of nothing is int64)
    out = {"floe_number": np.bincount(cell, w / floe_a, nc).astype(float, copy=False),
           "floe_area_mean": cell_means(cell, w, ice, floe_a, np.nan),
           "floe_caliper_mean": cell_means(cell, w, ice, floes.caliper[floes.label][el],
                                           np.nan)}
    if with_concentration:
        out["concentration"] = ice / grid.cell_area.ravel()
    return out


def scene_grid(path) -> dict | None:
    """The ``[output.grid]`` table of the scene an output file records (``None``: none)."""
    import tomllib

    from siku_io.output.results import open_results

    with open_results(path) as f:
        text = f["scene"][()].decode()
    try:
        cfg = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return None
    return (cfg.get("output") or {}).get("grid")
