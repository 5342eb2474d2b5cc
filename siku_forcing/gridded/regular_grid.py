"""Regular grids on the model Earth and the exact overlap of element polygons with their cells.

Two kinds (``[output.grid]`` of a scene, ``siku grid``, and the exchange grid of a coupling):

* ``lonlat``: cells bounded by meridians and parallels, ``lon = [west, east]``,
  ``lat = [south, north]`` [degrees], ``resolution`` [degrees] (or ``dlon``/``dlat``); ``east``
  may exceed 180 (``lon = [170, 190]`` spans the antimeridian), up to a whole circle;
* ``polar_stereographic``: square cells of the polar stereographic projection of the model
  sphere (``hemisphere``, ``central_longitude``, ``true_scale_latitude``: by default those of the
  NSIDC sea-ice grids, -45° and 70°), ``x = [x0, x1]``, ``y = [y0, y1]`` and ``resolution``
  [m] in projected metres (exact at the true-scale latitude).

Overlap (:meth:`Grid.overlap`): each element's polygon is taken into the grid's own plane (lon/lat
degrees, or projected metres; vertices mapped exactly, edges straight in that plane) and clipped
against the cells, which are exact rectangles there (``shapely``): the pieces of one polygon sum
to the whole polygon to round-off. ``fraction[element, cell]`` = piece area / polygon area in
that plane, and an element contributes ``fraction × area`` of its model area (m², its tangent
plane) to a cell, so the ice area on the grid equals the ice area of the elements on it to
round-off. The fractions differ from the true (spherical) ones by the change of the map's scale
across one element: ``(element size / Earth radius)`` times a factor of order one, under 1e-3 for
elements of 10 km.

``cell_area`` [m²] is the true area of each cell on the sphere (exact for ``lonlat``; 6 × 6
Gauss-Legendre quadrature of the projection's area factor for ``polar_stereographic``, exact to
round-off for cells of any size used in practice).
"""
from __future__ import annotations

import math
from functools import cached_property
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from siku_core import DataError

GRID_KINDS = ("lonlat", "polar_stereographic")


class GridCfg(BaseModel):
    """``[output.grid]``: the grid, what goes on it and when
    (``siku_forcing.gridded.regular_grid``)."""

    model_config = ConfigDict(extra="forbid")

    kind: Literal["lonlat", "polar_stereographic"] = "lonlat"
    lon: tuple[float, float] | None = Field(None, description="[west, east] degrees (lonlat)")
    lat: tuple[float, float] | None = Field(None, description="[south, north] degrees (lonlat)")
    x: tuple[float, float] | None = Field(None, description="[x0, x1] m (polar_stereographic)")
    y: tuple[float, float] | None = Field(None, description="[y0, y1] m (polar_stereographic)")
    resolution: float | None = Field(None, gt=0, description="cell size: degrees (lonlat) or "
                                     "m (polar_stereographic)")
    dlon: float | None = Field(None, gt=0, description="cell width [degrees] (lonlat)")
    dlat: float | None = Field(None, gt=0, description="cell height [degrees] (lonlat)")
    hemisphere: Literal["north", "south"] = "north"
    central_longitude: float = Field(-45.0, description="meridian pointing down the y axis "
                                     "(north) or up it (south) [degrees]")
    true_scale_latitude: float = Field(70.0, description="latitude of true scale [degrees]")
    every: str | float | None = Field(None, description="interval between gridded times "
                                      "(default: every snapshot)")
    file: str | None = Field(None, description="NetCDF file (default: OUTPUT.grid.nc)")
    fields: list[str] | None = Field(None, description="fields to write (default: all)")
    min_elements: int = Field(3, ge=3, description="strain rates: fewest element centres in "
                              "a cell")
    min_hull: float = Field(0.1, ge=0, le=1, description="strain rates: smallest area of the "
                            "centres' hull as a share of the cell")
    leads: bool = Field(True, description="detect leads (linear kinematic features) on the "
                        "gridded deformation")
    lead_threshold: float = Field(1.0, gt=0, description="leads: total deformation above "
                                  "which a cell is part of a lead [1/day]")
    lead_min_length: int = Field(3, ge=2, description="leads: shortest lead [cells]")

    @model_validator(mode="after")
    def _extent(self):
        if self.kind == "lonlat":
            if self.lon is None or self.lat is None:
                raise ValueError("a lonlat grid needs lon = [west, east] and lat = [south, "
                                 "north] (degrees)")
            if not (self.resolution or (self.dlon and self.dlat)):
                raise ValueError("a lonlat grid needs resolution (degrees) or dlon and dlat")
            w, e = self.lon
            s, n = self.lat
            if not (w < e <= w + 360.0):
                raise ValueError(f"lon = [{w}, {e}]: need west < east <= west + 360")
            if not (-90.0 <= s < n <= 90.0):
                raise ValueError(f"lat = [{s}, {n}]: need -90 <= south < north <= 90")
        else:
            if self.x is None or self.y is None or not self.resolution:
                raise ValueError("a polar_stereographic grid needs x = [x0, x1], y = [y0, y1] "
                                 "and resolution (m)")
            if not (self.x[0] < self.x[1] and self.y[0] < self.y[1]):
                raise ValueError("x and y need x0 < x1 and y0 < y1")
            if not 0.0 < abs(self.true_scale_latitude) <= 90.0:
                raise ValueError("true_scale_latitude must be in (0, 90]")
        return self


def _edges(lo: float, hi: float, step: float, what: str, table: str) -> np.ndarray:
    n = int(round((hi - lo) / step))
    if n < 1 or abs(lo + n * step - hi) > 1e-9 * max(abs(step), 1.0) * max(n, 1):
        raise DataError(f"{table} {what}: the extent {hi - lo:g} is not a whole number "
                        f"of cells of {step:g}")
    if n > 20000:
        raise DataError(f"{table} {what}: {n} cells along one axis; choose a coarser "
                        "resolution")
    return lo + step * np.arange(n + 1)


class Grid:
    """A regular grid on a sphere of radius ``radius`` [m] (module docstring); ``table`` names
    it in error messages."""

    def __init__(self, cfg: GridCfg, radius: float, table: str = "[output.grid]"):
        self.cfg = cfg
        self.kind = cfg.kind
        self.radius = float(radius)
        if cfg.kind == "lonlat":
            dx = cfg.dlon or cfg.resolution
            dy = cfg.dlat or cfg.resolution
            self.x_edges = _edges(cfg.lon[0], cfg.lon[1], dx, "lon", table)
            self.y_edges = _edges(cfg.lat[0], cfg.lat[1], dy, "lat", table)
        else:
            self.x_edges = _edges(cfg.x[0], cfg.x[1], cfg.resolution, "x", table)
            self.y_edges = _edges(cfg.y[0], cfg.y[1], cfg.resolution, "y", table)
            self.sign = 1.0 if cfg.hemisphere == "north" else -1.0
            ts = math.radians(abs(cfg.true_scale_latitude))
            #: the scale factor at the pole: rho = 2 R k0 tan(pi/4 - |lat|/2)
            self.k0 = 0.5 * (1.0 + math.sin(ts))
        self.nx = len(self.x_edges) - 1
        self.ny = len(self.y_edges) - 1

    # -------------------------------------------------------------- coordinates
    @property
    def shape(self) -> tuple[int, int]:
        return self.ny, self.nx

    @property
    def x(self) -> np.ndarray:
        """Cell centres along x: longitude [degrees] or projected x [m]."""
        return 0.5 * (self.x_edges[:-1] + self.x_edges[1:])

    @property
    def y(self) -> np.ndarray:
        return 0.5 * (self.y_edges[:-1] + self.y_edges[1:])

    @cached_property
    def proj4(self) -> str:
        c = self.cfg
        lat0 = 90 if c.hemisphere == "north" else -90
        return (f"+proj=stere +lat_0={lat0} +lat_ts={self.sign * abs(c.true_scale_latitude)} "
                f"+lon_0={c.central_longitude} +x_0=0 +y_0=0 +R={self.radius} +units=m "
                "+no_defs")

    def to_plane(self, lon, lat) -> tuple[np.ndarray, np.ndarray]:
        """Grid-plane coordinates of points [degrees]: ``lonlat``: longitude wrapped into
        ``[west, west + 360)`` and latitude; ``polar_stereographic``: projected x, y [m] (the
        spherical formulas that PROJ's ``stere`` uses with ``+R``)."""
        lon = np.asarray(lon, dtype=float)
        lat = np.asarray(lat, dtype=float)
        if self.kind == "lonlat":
            w = self.x_edges[0]
            return w + np.mod(lon - w, 360.0), lat
        lam = np.radians(lon - self.cfg.central_longitude)
        phi = np.radians(lat) * self.sign
        rho = 2.0 * self.radius * self.k0 * np.tan(0.25 * math.pi - 0.5 * phi)
        return rho * np.sin(lam), -self.sign * rho * np.cos(lam)

    def to_lonlat(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Longitude and latitude [degrees] of grid-plane points (inverse of :meth:`to_plane`)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if self.kind == "lonlat":
            return ((x + 180.0) % 360.0) - 180.0, y
        rho = np.hypot(x, y)
        phi = 0.5 * math.pi - 2.0 * np.arctan(rho / (2.0 * self.radius * self.k0))
        lam = np.arctan2(x, -self.sign * y)
        lon = self.cfg.central_longitude + np.degrees(lam)
        return ((lon + 180.0) % 360.0) - 180.0, self.sign * np.degrees(phi)

    def axes(self, lon, lat) -> tuple[np.ndarray, np.ndarray]:
        """Angle [rad] of the grid's x axis from local east, counter-clockwise, at points
        [degrees]: a vector with east/north components ``(u, v)`` has grid components
        ``(u cos a + v sin a, -u sin a + v cos a)`` with ``a`` this angle. 0 on a lonlat grid
        (its axes are east and north)."""
        lon = np.asarray(lon, dtype=float)
        if self.kind == "lonlat":
            return np.zeros_like(lon)
        lam = np.radians(lon - self.cfg.central_longitude)
        # east is (cos lam, sin lam) in the plane (north), (cos lam, -sin lam) (south), so the
        # x axis lies at -lam (north) or +lam (south) from east
        return -self.sign * lam

    def rotate(self, u, v, lon) -> tuple[np.ndarray, np.ndarray]:
        """Grid components of vectors with east/north components ``(u, v)`` at longitudes
        ``lon`` [degrees]."""
        a = self.axes(lon, lon)
        ca, sa = np.cos(a), np.sin(a)
        return u * ca + v * sa, -u * sa + v * ca

    def local_metres(self, lon, lat, iy, ix) -> tuple[np.ndarray, np.ndarray]:
        """Positions [m] of points in a plane of cell ``(iy, ix)`` where the strain rates are
        computed: the projected plane itself (``polar_stereographic``), or the equirectangular
        plane about the cell centre, ``x = R cos(lat_c) (lon - lon_c)``, ``y = R (lat -
        lat_c)`` (``lonlat``)."""
        X, Y = self.to_plane(lon, lat)
        if self.kind != "lonlat":
            return X, Y
        lonc, latc = self.x[ix], self.y[iy]
        R = self.radius
        return (R * math.cos(math.radians(latc)) * np.radians(X - lonc),
                R * np.radians(Y - latc))

    @cached_property
    def cell_area(self) -> np.ndarray:
        """True area of every cell on the sphere [m²], ``(ny, nx)``."""
        R = self.radius
        if self.kind == "lonlat":
            s = np.sin(np.radians(self.y_edges))
            dl = np.radians(np.diff(self.x_edges))
            return R * R * np.outer(np.diff(s), dl)
        g, wts = np.polynomial.legendre.leggauss(6)
        x0, x1 = self.x_edges[:-1], self.x_edges[1:]
        y0, y1 = self.y_edges[:-1], self.y_edges[1:]
        xs = 0.5 * (x0 + x1)[None, :, None] + 0.5 * (x1 - x0)[None, :, None] * g[None, None, :]
        ys = 0.5 * (y0 + y1)[:, None, None] + 0.5 * (y1 - y0)[:, None, None] * g[None, None, :]
        a = 4.0 * R * R * self.k0 * self.k0
        total = np.zeros(self.shape)
        for b in range(len(g)):  # area factor 1/k² = a² / (a + rho²)² of the stereographic map
            rho2 = xs ** 2 + ys[:, :, b:b + 1] ** 2
            total += wts[b] * np.sum(wts[None, None, :] * a * a / (self.k0 ** 2 * (a + rho2) ** 2),
                                   axis=2)
        return total * 0.25 * np.outer(y1 - y0, x1 - x0)

    @cached_property
    def centres_lonlat(self) -> tuple[np.ndarray, np.ndarray]:
        """Longitude and latitude [degrees] of the cell centres, ``(ny, nx)`` each."""
        X, Y = np.meshgrid(self.x, self.y)
        return self.to_lonlat(X, Y)

    # -------------------------------------------------------------- polygons
    def polygons(self, node_lon, node_lat, offsets, centre_lon) -> tuple[list, np.ndarray]:
        """Every element's polygon in the grid plane as ``(k, 2)`` arrays, and the element of
        each (a lonlat polygon that a whole-circle grid wraps appears twice: its shifted copy
        too). ``offsets``: CSR offsets of the nodes (N + 1)."""
        X, Y = self.to_plane(node_lon, node_lat)
        polys, owner = [], []
        if self.kind == "lonlat":
            cx, _ = self.to_plane(centre_lon, np.zeros_like(centre_lon))
            w, e = self.x_edges[0], self.x_edges[-1]
            for i in range(len(offsets) - 1):
                a, b = offsets[i], offsets[i + 1]
                # unwrap the vertices about the centre: no jump at the antimeridian
                px = cx[i] + ((X[a:b] - cx[i] + 180.0) % 360.0) - 180.0
                if px.max() - px.min() > 180.0:
                    raise DataError(f"element {i}: encloses a pole; a lonlat grid cannot hold "
                                    "it (use kind = \"polar_stereographic\")")
                p = np.column_stack([px, Y[a:b]])
                polys.append(p)
                owner.append(i)
                for shift in (-360.0, 360.0):  # a copy that reaches into the grid from outside
                    lo, hi = px.min() + shift, px.max() + shift
                    if hi > w and lo < e:
                        polys.append(p + [shift, 0.0])
                        owner.append(i)
        else:
            for i in range(len(offsets) - 1):
                a, b = offsets[i], offsets[i + 1]
                polys.append(np.column_stack([X[a:b], Y[a:b]]))
                owner.append(i)
        return polys, np.asarray(owner, dtype=np.int64)

    def overlap(self, node_lon, node_lat, offsets, centre_lon, cover=None):
        """Sparse overlap of elements and cells: ``(element, cell, fraction)`` arrays, ``cell``
        the flat index ``iy * nx + ix``, ``fraction`` the share of the element's polygon in the
        cell (module docstring).

        With ``cover`` (per element, the share of its footprint its ice covers, 0-1), a fourth
        array too: the share of the element's polygon that its *ice* covers in the cell: its
        open water, ``(1 - cover)`` of the polygon, lies first where the polygon
        overlaps other elements' (where the ice it lost went, under a ridge), spread evenly
        over that overlap, and only what is left over the rest of the polygon
        (:func:`ice_shares`); ``cover`` times the plain share where ``cover = 1``."""
        import shapely

        polys, owner = self.polygons(node_lon, node_lat, offsets, centre_lon)
        if not polys:
            return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
        nodes = np.concatenate(polys)
        counts = np.array([len(p) for p in polys])
        ring = np.repeat(np.arange(len(polys)), counts)
        shapes = shapely.polygons(shapely.linearrings(nodes, indices=ring))
        whole = shapely.area(shapes)
        xe, ye = self.x_edges, self.y_edges
        lo = np.minimum.reduceat(nodes, np.r_[0, np.cumsum(counts)[:-1]])
        hi = np.maximum.reduceat(nodes, np.r_[0, np.cumsum(counts)[:-1]])
        ix0 = np.clip(np.searchsorted(xe, lo[:, 0], side="right") - 1, 0, self.nx - 1)
        ix1 = np.clip(np.searchsorted(xe, hi[:, 0], side="left") - 1, 0, self.nx - 1)
        iy0 = np.clip(np.searchsorted(ye, lo[:, 1], side="right") - 1, 0, self.ny - 1)
        iy1 = np.clip(np.searchsorted(ye, hi[:, 1], side="left") - 1, 0, self.ny - 1)
        inside = (hi[:, 0] > xe[0]) & (lo[:, 0] < xe[-1]) & (hi[:, 1] > ye[0]) & (
            lo[:, 1] < ye[-1])
        nxs = np.where(inside, ix1 - ix0 + 1, 0)
        nys = np.where(inside, iy1 - iy0 + 1, 0)
        per = nxs * nys
        pid = np.repeat(np.arange(len(polys)), per)
        k = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
        ix = ix0[pid] + k % nxs[pid]
        iy = iy0[pid] + k // nxs[pid]
        boxes = shapely.box(xe[ix], ye[iy], xe[ix + 1], ye[iy + 1])
        piece = shapely.area(shapely.intersection(shapes[pid], boxes))
        keep = piece > 0.0
        frac = piece[keep] / whole[pid[keep]]
        if cover is not None:
            return (owner[pid[keep]], (iy * self.nx + ix)[keep], frac,
                    ice_shares(shapes, owner, np.asarray(cover, float), pid[keep], boxes[keep],
                               piece[keep], whole))
        return owner[pid[keep]], (iy * self.nx + ix)[keep], frac

    # -------------------------------------------------------------- CF description
    def cf_coords(self) -> dict:
        """CF coordinate variables and the grid mapping: ``{name: (dims, values, attrs)}``."""
        lon2, lat2 = self.centres_lonlat
        if self.kind == "lonlat":
            return {
                "lon": (("lon",), self.x, {"units": "degrees_east",
                                           "standard_name": "longitude", "axis": "X",
                                           "long_name": "longitude of the cell centre",
                                           "bounds": "lon_bnds"}),
                "lat": (("lat",), self.y, {"units": "degrees_north",
                                           "standard_name": "latitude", "axis": "Y",
                                           "long_name": "latitude of the cell centre",
                                           "bounds": "lat_bnds"}),
                "lon_bnds": (("lon", "nv"), np.column_stack([self.x_edges[:-1],
                                                            self.x_edges[1:]]), {}),
                "lat_bnds": (("lat", "nv"), np.column_stack([self.y_edges[:-1],
                                                            self.y_edges[1:]]), {}),
            }
        c = self.cfg
        return {
            "x": (("x",), self.x, {"units": "m", "standard_name": "projection_x_coordinate",
                                   "long_name": "x of the cell centre", "axis": "X"}),
            "y": (("y",), self.y, {"units": "m", "standard_name": "projection_y_coordinate",
                                   "long_name": "y of the cell centre", "axis": "Y"}),
            "lon": (("y", "x"), lon2, {"units": "degrees_east", "standard_name": "longitude",
                                       "long_name": "longitude of the cell centre"}),
            "lat": (("y", "x"), lat2, {"units": "degrees_north", "standard_name": "latitude",
                                       "long_name": "latitude of the cell centre"}),
            "crs": ((), np.int32(0), {
                "long_name": "polar stereographic projection of the model sphere",
                "grid_mapping_name": "polar_stereographic",
                "straight_vertical_longitude_from_pole": c.central_longitude,
                "latitude_of_projection_origin": 90.0 * self.sign,
                "standard_parallel": self.sign * abs(c.true_scale_latitude),
                "false_easting": 0.0, "false_northing": 0.0,
                "earth_radius": self.radius, "proj4text": self.proj4}),
        }

    @property
    def dims(self) -> tuple[str, str]:
        """Names of the grid's dimensions in files: ``(lat, lon)`` or ``(y, x)``."""
        return ("lat", "lon") if self.kind == "lonlat" else ("y", "x")


def grid_error(exc: Exception, where: str) -> DataError:
    """One line per problem of a grid table that does not validate."""
    from pydantic import ValidationError

    if isinstance(exc, ValidationError):
        from siku_core.scene.scene_messages import explain_validation_error

        return DataError(explain_validation_error(exc, where, GridCfg))
    return DataError(f"{where}: {exc}")


def cell_means(cell, weights, weight_sums, values, empty: float) -> np.ndarray:
    """Per cell, the mean of ``values`` (one per element-cell overlap) with ``weights``, whose
    per-cell sums are ``weight_sums``; ``empty`` in cells without weight (NaN for a gridded
    file, 0 for the coupling's exchange grid, which must hand over finite numbers)."""
    safe = np.where(weight_sums > 0, weight_sums, 1.0)
    return np.where(weight_sums > 0,
                    np.bincount(cell, weights * values, len(weight_sums)) / safe, empty)


def ice_shares(shapes, owner, cover, pid, boxes, piece, whole) -> np.ndarray:
    """The share of each polygon ``pid`` (of ``shapes``, owned by element ``owner[pid]``) that
    its element's ice covers in the cell ``boxes`` (its ``piece`` of area ``whole`` lies in
    the cell), for elements whose ice covers ``cover`` of their footprint: the open water,
    ``W = (1 - cover) whole``, lies first in the polygon's overlap ``O`` with the polygons of
    other elements (the footprint a ridging giver ceded lies under the carrier), evenly over
    it; what ``O`` cannot hold (``W > |O|``) evenly over the rest. So the cell gets open water
    ``W |O ∩ cell| / |O|`` (``W <= |O|``) or ``|O ∩ cell| + (W - |O|) (piece - |O ∩ cell|) /
    (whole - |O|)``, and the share is ``(piece - open) / whole``; with ``cover = 1`` it is
    ``piece / whole`` to the bit. The areas are the grid plane's (as the overlap's)."""
    import shapely

    c = np.clip(cover[owner], 0.0, 1.0)
    out = piece / whole[pid] * c[pid]
    need = np.unique(pid[c[pid] < 1.0])
    if not len(need):
        return out
    tree = shapely.STRtree(shapes)
    ov = {}
    for p in need:
        near = tree.query(shapes[p], predicate="intersects")
        near = near[owner[near] != owner[p]]
        ov[p] = (shapely.union_all(shapely.intersection(shapes[p], shapes[near])) if len(near)
                 else None)
    k = np.flatnonzero(c[pid] < 1.0)
    for i in k:
        p = pid[i]
        water = (1.0 - c[p]) * whole[p]
        o = ov[p]
        area_o = 0.0 if o is None else float(shapely.area(o))
        in_box = (0.0 if area_o <= 0.0
                  else float(shapely.area(shapely.intersection(o, boxes[i]))))
        if area_o > 0.0 and water <= area_o:
            open_ = water * in_box / area_o
        else:
            rest = whole[p] - area_o
            open_ = (in_box + (water - area_o) * (piece[i] - in_box) / rest if rest > 0.0
                     else piece[i])
        out[i] = max(piece[i] - open_, 0.0) / whole[p]
    return out

