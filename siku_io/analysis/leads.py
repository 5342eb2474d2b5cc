"""Leads as numbers: linear kinematic features (LKFs) found in gridded deformation and in the
broken joints on the grid, each with its length, orientation, ends and opening, and the angles
at which they cross.

The image steps are scikit-image's (after the LKF detection of Linow & Dierking 2017 and Hutter
et al. 2019, simplified):

1. a mask of the cells where the total deformation exceeds ``lead_threshold`` [1/day] (or,
   for open leads, where a joint has broken);
2. its skeleton (``skimage.morphology.skeletonize``), one cell wide;
3. junctions: skeleton cells with three or more branches leaving them (crossing number of the
   8-neighbourhood); removing the skeleton within two cells of each junction splits it into
   branches (``skimage.measure.label``, 8-connected), and junctions that close are one;
4. at each junction the branches are paired when their directions differ by less than
   ``MERGE_ANGLE`` (closest first): a lead that a crossing lead cut in two is one lead again;
5. each lead at least ``lead_min_length`` cells long: its orientation is the principal axis of
   its cells (degrees counter-clockwise from the grid's x axis, in [0, 180)), its length the
   distance along that axis between the centres of its two end cells (its ends);
   ``opening`` is the velocity jump across it, the integral of the divergence over its cells
   divided by its extent along itself (length plus one cell) [m/s] (positive: opening,
   negative: closing): exact for a jump spread over a band one cell wide;
6. an intersection is a junction where two different leads meet: the acute angle between
   them [degrees] and where.

Positions are metres in the grid's plane (polar stereographic), or in the plane about the lead's
centre (lonlat: ``x = R cos(lat_c) (lon - lon_c)``, ``y = R (lat - lat_c)``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: largest difference of direction [degrees] for two branches at a junction to be one lead
MERGE_ANGLE = 25.0
#: junctions at most this many cells apart (chessboard distance) are one crossing: the skeleton
#: of a crossing of bands two cells wide is two forks joined by a short stub
JOIN_CELLS = 3
#: broken-joint leads: the widest mask, in cells (mask cells per skeleton cell), in which each
#: lead is one crack. A crack's broken joints put their midpoints in a chain of cells one cell
#: wide; a wider mask holds cracks side by side closer than a cell, which the skeleton merges
#: into one lead or a web: the table of that time is refused
MAX_CRACK_WIDTH = 1.5
#: broken-joint leads: the largest share of the skeleton the crossings' zones may take; above
#: it the leads are no longer than the crossings between them, and the table is refused
MAX_ZONE_SHARE = 0.75
LEAD_KINDS = {1: "deformation", 2: "broken_joints"}
# the 8-neighbourhood in ring order (for the crossing number)
_RING = ((-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1))


@dataclass
class Lead:
    cells: np.ndarray  # (k, 2) row, column
    length: float  # m
    orientation: float  # degrees from the x axis, [0, 180)
    centre: tuple[float, float]  # lon, lat
    ends: tuple[tuple[float, float], tuple[float, float]]  # (lon, lat) of both ends
    opening: float  # m/s


@dataclass
class Crossing:
    leads: tuple[int, int]
    angle: float  # degrees, (0, 90]
    where: tuple[float, float]  # lon, lat


def _shift(a: np.ndarray, dy: int, dx: int) -> np.ndarray:
    out = np.zeros_like(a)
    ny, nx = a.shape
    out[max(dy, 0):ny + min(dy, 0), max(dx, 0):nx + min(dx, 0)] = \
        a[max(-dy, 0):ny + min(-dy, 0), max(-dx, 0):nx + min(-dx, 0)]
    return out


def junctions(skel: np.ndarray) -> np.ndarray:
    """Skeleton cells where three or more branches meet: crossing number (0 -> 1 transitions
    around the 8-neighbourhood) of at least 3, or at least 4 neighbours."""
    ring = [_shift(skel, -dy, -dx).astype(np.int8) for dy, dx in _RING]
    cross = sum(((ring[k] == 0) & (ring[(k + 1) % 8] == 1)) for k in range(8))
    count = sum(ring)
    return skel & ((cross >= 3) | (count >= 4))


class _Union:
    def __init__(self, n):
        self.p = list(range(n))

    def find(self, a):
        while self.p[a] != a:
            self.p[a] = self.p[self.p[a]]
            a = self.p[a]
        return a

    def join(self, a, b):
        self.p[self.find(a)] = self.find(b)


def _axis(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit principal axis of points and its angle [degrees, 0-180)."""
    d = xy - xy.mean(axis=0)
    if len(xy) < 2:
        return np.array([1.0, 0.0]), 0.0
    w, v = np.linalg.eigh(d.T @ d)
    ax = v[:, np.argmax(w)]
    return ax, float(np.degrees(np.arctan2(ax[1], ax[0])) % 180.0)


def _angle_between(a: float, b: float) -> float:
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)


def detect(mask: np.ndarray, grid, divergence: np.ndarray | None = None,
           min_length: int = 3) -> tuple[list[Lead], list[Crossing]]:
    """Leads and their crossings in a boolean ``mask`` ``(ny, nx)`` on ``grid`` (module
    docstring); ``divergence`` [1/s] gives each lead's opening."""
    branches, zones = _branches_and_zones(np.asarray(mask, bool))
    nb = int(branches.max())
    metres = _planar_metres(grid)
    cells = [np.argwhere(branches == b + 1) for b in range(nb)]
    angle = [_axis(metres(rc))[1] if len(rc) else 0.0 for rc in cells]
    groups, touch_zone = _join_branches(branches, zones, angle)
    side_x, side_y = _cell_sides(grid)
    leads: list[Lead] = []
    owner = {}
    for members in groups:
        rc = np.concatenate([cells[b] for b in members])
        # the junction cells between two joined branches belong to the lead
        for z, bs in touch_zone.items():
            if sum(b in members for b in bs) >= 2:
                rc = np.concatenate([rc, np.argwhere(zones == z)])
        lead = _lead_of(rc, grid, metres, side_x, side_y, divergence, min_length)
        if lead is None:
            continue
        for b in members:
            owner[b] = len(leads)
        leads.append(lead)
    return leads, _crossings(grid, zones, touch_zone, owner, leads)


def _branches_and_zones(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The labelled branches of the mask's skeleton and the labelled junction zones between
    them. A zone is a junction and the skeleton within two cells of it: two junctions that
    close (the skeleton of a crossing of wide bands is two forks joined by a stub) are one
    crossing."""
    from scipy.ndimage import binary_dilation
    from skimage.measure import label
    from skimage.morphology import skeletonize

    skel = skeletonize(mask)
    junc = junctions(skel)
    zone = binary_dilation(junc, structure=np.ones((3, 3), bool), iterations=2) & skel
    return label(skel & ~zone, connectivity=2), _junction_zones(junc, zone)


def _junction_zones(junc: np.ndarray, zone: np.ndarray) -> np.ndarray:
    """Label the zone cells by junction cluster: junction cells within ``JOIN_CELLS`` of each
    other (chessboard distance) are one crossing; every zone cell goes to its nearest junction's
    cluster. (Labelling the connected zones instead chained the zones of a network of junctions
    into one, which every lead of the network touched: all of them "crossed" at one point.)"""
    from scipy.ndimage import distance_transform_cdt
    from skimage.measure import label

    lab = label(junc, connectivity=2)
    n = int(lab.max())
    if n == 0:
        return np.zeros(junc.shape, np.int64)
    cells = [np.argwhere(lab == k + 1) for k in range(n)]
    uf = _Union(n)
    for a in range(n):
        for b in range(a + 1, n):
            d = np.abs(cells[a][:, None, :] - cells[b][None, :, :]).max(axis=2).min()
            if d <= JOIN_CELLS:
                uf.join(a, b)
    roots = {}
    cluster = np.array([roots.setdefault(uf.find(k), len(roots) + 1) for k in range(n)])
    _, idx = distance_transform_cdt(~junc, metric="chessboard", return_indices=True)
    nearest = lab[idx[0], idx[1]]
    out = np.zeros(junc.shape, np.int64)
    out[zone] = cluster[nearest[zone] - 1]
    return out


def _planar_metres(grid):
    """A function of cells ``rc`` ``(k, 2)`` (row, column) giving their centres ``(k, 2)`` [m]
    in a plane: the grid's own x, y, or on a lon/lat grid a local equirectangular projection
    about the cells' mean longitude and latitude."""
    X, Y = np.meshgrid(grid.x, grid.y)
    lon_c, lat_c = grid.centres_lonlat

    def metres(rc: np.ndarray) -> np.ndarray:
        r, c = rc[:, 0], rc[:, 1]
        if grid.kind != "lonlat":
            return np.column_stack([X[r, c], Y[r, c]])
        lat0 = np.radians(lat_c[r, c].mean())
        lon = lon_c[r, c]
        lon0 = lon.mean()
        R = grid.radius
        return np.column_stack([R * np.cos(lat0) * np.radians(((lon - lon0 + 180) % 360) - 180),
                                R * np.radians(lat_c[r, c] - lat_c[r, c].mean())])

    return metres


def _join_branches(branches: np.ndarray, zones: np.ndarray,
                   angle: list[float]) -> tuple[list[list[int]], dict[int, list[int]]]:
    """The branches grouped into leads, and the branches touching each junction zone. At each
    zone the pairs of branches closest in direction (``angle`` [degrees]) are joined, each
    branch at most once, while they differ by less than :data:`MERGE_ANGLE`."""
    from scipy.ndimage import binary_dilation

    nb = int(branches.max())
    uf = _Union(nb)
    touch_zone: dict[int, list[int]] = {}
    for z in range(1, int(zones.max()) + 1):
        ring = binary_dilation(zones == z, structure=np.ones((3, 3), bool))
        touching = sorted(set(np.unique(branches[ring])) - {0})
        touch_zone[z] = [b - 1 for b in touching]
        pairs = sorted(((_angle_between(angle[a], angle[b]), a, b)
                        for k, a in enumerate(touch_zone[z]) for b in touch_zone[z][k + 1:]))
        used: set[int] = set()
        for d, a, b in pairs:
            if d < MERGE_ANGLE and a not in used and b not in used:
                uf.join(a, b)
                used.update((a, b))
    groups: dict[int, list[int]] = {}
    for b in range(nb):
        groups.setdefault(uf.find(b), []).append(b)
    return list(groups.values()), touch_zone


def _cell_sides(grid) -> tuple[np.ndarray, np.ndarray]:
    """The sides [m] of every grid cell along x (east) and y (north), ``(ny, nx)`` each."""
    if grid.kind == "lonlat":
        _, lat_c = grid.centres_lonlat
        dlon = np.radians(np.diff(grid.x_edges))[None, :] * np.ones(grid.shape)
        dlat = np.radians(np.diff(grid.y_edges))[:, None] * np.ones(grid.shape)
        return grid.radius * np.cos(np.radians(lat_c)) * dlon, grid.radius * dlat
    return (np.diff(grid.x_edges)[None, :] * np.ones(grid.shape),
            np.diff(grid.y_edges)[:, None] * np.ones(grid.shape))


def _lead_of(rc: np.ndarray, grid, metres, side_x: np.ndarray, side_y: np.ndarray,
             divergence: np.ndarray | None, min_length: int) -> Lead | None:
    """The lead made of cells ``rc``, or None when it is shorter than ``min_length`` cells:
    its length [m] along its principal axis, orientation [degrees], centre and ends (lon,
    lat), and opening [m/s] (the divergence integrated over the band per unit length)."""
    lon_c, lat_c = grid.centres_lonlat
    xy = metres(rc)
    ax, ang = _axis(xy)
    proj = (xy - xy.mean(axis=0)) @ ax
    sx, sy = side_x[rc[:, 0], rc[:, 1]], side_y[rc[:, 0], rc[:, 1]]
    w = float(np.mean(np.abs(sx * ax[0]) + np.abs(sy * ax[1])))  # one cell along the lead
    length = float(proj.max() - proj.min())
    if length < (min_length - 1) * w * (1 - 1e-6):
        return None
    e0, e1 = rc[np.argmin(proj)], rc[np.argmax(proj)]
    opening = np.nan
    if divergence is not None:
        dv = divergence[rc[:, 0], rc[:, 1]]
        ok = np.isfinite(dv)
        if ok.any():  # integral over the band / its extent along the lead
            opening = float(np.sum(dv[ok] * sx[ok] * sy[ok]) / (ok.mean() * (length + w)))
    return Lead(rc, length, ang, _mean_lonlat(grid, rc),
                ((float(lon_c[e0[0], e0[1]]), float(lat_c[e0[0], e0[1]])),
                 (float(lon_c[e1[0], e1[1]]), float(lat_c[e1[0], e1[1]]))), opening)


def _mean_lonlat(grid, rc: np.ndarray) -> tuple[float, float]:
    """Lon/lat [deg] of the mean of cells ``rc`` ``(k, 2)``: in the grid's plane (a mean of
    longitudes is wrong near a pole and across the date line), or on a lonlat grid the mean
    latitude and the circular mean longitude."""
    lon_c, lat_c = grid.centres_lonlat
    r, c = rc[:, 0], rc[:, 1]
    if grid.kind != "lonlat":
        X, Y = np.meshgrid(grid.x, grid.y)
        lon, lat = grid.to_lonlat(np.array([X[r, c].mean()]), np.array([Y[r, c].mean()]))
        return float(np.ravel(lon)[0]), float(np.ravel(lat)[0])
    a = np.radians(lon_c[r, c])
    return (float(np.degrees(np.arctan2(np.sin(a).mean(), np.cos(a).mean()))),
            float(lat_c[r, c].mean()))


def _crossings(grid, zones: np.ndarray, touch_zone: dict[int, list[int]], owner: dict[int, int],
               leads: list[Lead]) -> list[Crossing]:
    """Every pair of leads meeting at a junction zone, with the angle [degrees] between them
    and the zone's mean position."""
    crossings: list[Crossing] = []
    for z, bs in touch_zone.items():
        ids = sorted({owner[b] for b in bs if b in owner})
        where = _mean_lonlat(grid, np.argwhere(zones == z))
        for k, a in enumerate(ids):
            for b in ids[k + 1:]:
                crossings.append(Crossing((a, b), _angle_between(
                    leads[a].orientation, leads[b].orientation), where))
    return crossings


def crack_width(mask: np.ndarray) -> float:
    """Mean width of a mask [cells]: its cells per cell of its skeleton (1 for a chain of
    cells; 0 for an empty mask)."""
    from skimage.morphology import skeletonize

    m = np.asarray(mask, bool)
    n = int(skeletonize(m).sum())
    return float(m.sum()) / n if n else 0.0


def unresolved(mask: np.ndarray) -> str | None:
    """Why the broken-joint leads of ``mask`` cannot be measured on its grid, or ``None``:
    the mask is wider than :data:`MAX_CRACK_WIDTH` cells (cracks side by side closer than a
    cell), or the crossings' zones (the skeleton within two cells of a junction) take more than
    :data:`MAX_ZONE_SHARE` of the skeleton (leads no longer than their crossings)."""
    m = np.asarray(mask, bool)
    if not m.any():
        return None
    width = crack_width(m)
    if width > MAX_CRACK_WIDTH:
        return (f"the broken-joint mask is {width:.2f} cells wide (above {MAX_CRACK_WIDTH:g}): "
                "cracks closer than a cell cannot be told apart")
    branches, zones = _branches_and_zones(m)
    share = float((zones > 0).sum()) / max(int((branches > 0).sum() + (zones > 0).sum()), 1)
    if share > MAX_ZONE_SHARE:
        return (f"crossings take {share:.0%} of the skeleton (above {MAX_ZONE_SHARE:.0%}): the "
                "leads are not longer than their crossings")
    for dy, dx in _RING:  # two crossings' zones side by side: no lead between them
        other = _shift(zones, dy, dx)
        if np.any((zones > 0) & (other > 0) & (zones != other)):
            return "crossings closer than five cells touch: the leads between them are lost"
    return None


def detect_series(grid, ds, cfg):
    """The leads of every time of a gridded dataset (``siku_io.analysis.gridded_fields``) as an
    ``xarray.Dataset`` of tables along ``lead`` and ``intersection``, and per time whether the
    broken-joint leads were resolved (``broken_joint_leads_resolved``): where :func:`unresolved`
    gives a reason, that time's broken-joint leads are refused (left out of the table, with a
    warning naming the time and the reason): the cells are too coarse for them."""
    import warnings

    import xarray as xr

    rows, xrows = [], []
    resolved = np.ones(ds.sizes["time"], bool)
    for t in range(ds.sizes["time"]):
        div = ds["divergence"].values[t] if "divergence" in ds else None
        masks = []
        if "total_deformation" in ds:
            tot = ds["total_deformation"].values[t] * 86400.0
            masks.append((1, np.nan_to_num(tot, nan=0.0) >= cfg.lead_threshold))
        if "broken_joints" in ds:
            m = ds["broken_joints"].values[t] > 0
            why = unresolved(m)
            if why is not None:
                resolved[t] = False
                warnings.warn(f"siku grid: broken-joint leads at time {ds['time'].values[t]!s} "
                              f"refused: {why} on this grid; use finer cells", stacklevel=2)
            else:
                masks.append((2, m))
        for kind, m in masks:
            found, cross = detect(m, grid, div if kind == 1 else None, cfg.lead_min_length)
            base = len(rows)
            for f in found:
                rows.append((t, kind, f))
            for c in cross:
                xrows.append((t, kind, c, base))
    tv = ds["time"].values
    T = {"long_name": "time of the gridded field", **{
        k: v for k, v in ds["time"].attrs.items() if k in ("units", "calendar")}}

    def var(dim, vals, units, long_name, **more):
        return xr.Variable(dim, np.asarray(vals), {"units": units, "long_name": long_name,
                                                   **more} if units is not None else
                           {"long_name": long_name, **more})

    kinds = {"flag_values": np.array(sorted(LEAD_KINDS), dtype=np.int8),
             "flag_meanings": " ".join(LEAD_KINDS[k] for k in sorted(LEAD_KINDS))}
    L = "lead"
    data = {
        "lead_time": xr.Variable(L, tv[[r[0] for r in rows]] if rows else tv[:0], T),
        "lead_kind": var(L, np.array([r[1] for r in rows], np.int8), None,
                         "what the lead was found in", **kinds),
        "lead_length": var(L, [r[2].length for r in rows], "m", "length of the lead"),
        "lead_orientation": var(L, [r[2].orientation for r in rows], "degree",
                                "direction of the lead, counter-clockwise from the grid x axis "
                                "(east on a lonlat grid), 0-180"),
        "lead_cells": var(L, np.array([len(r[2].cells) for r in rows], np.int32), "1",
                          "grid cells of the lead's skeleton"),
        "lead_lon": var(L, [r[2].centre[0] for r in rows], "degrees_east",
                        "longitude of the lead's centre"),
        "lead_lat": var(L, [r[2].centre[1] for r in rows], "degrees_north",
                        "latitude of the lead's centre"),
        "lead_opening": var(L, [r[2].opening for r in rows], "m s-1",
                            "velocity jump across the lead (opening positive)"),
    }
    for k, end in ((0, "start"), (1, "end")):
        data[f"lead_{end}_lon"] = var(L, [r[2].ends[k][0] for r in rows], "degrees_east",
                                      f"longitude of the lead's {end}")
        data[f"lead_{end}_lat"] = var(L, [r[2].ends[k][1] for r in rows], "degrees_north",
                                      f"latitude of the lead's {end}")
    X = "intersection"
    data.update({
        "intersection_time": xr.Variable(X, tv[[r[0] for r in xrows]] if xrows else tv[:0], T),
        "intersection_kind": var(X, np.array([r[1] for r in xrows], np.int8), None,
                                 "what the leads were found in", **kinds),
        "intersection_angle": var(X, [r[2].angle for r in xrows], "degree",
                                  "acute angle between the two leads"),
        "intersection_lead_a": var(X, np.array([r[3] + r[2].leads[0] for r in xrows],
                                               np.int32), "1", "index of one lead"),
        "intersection_lead_b": var(X, np.array([r[3] + r[2].leads[1] for r in xrows],
                                               np.int32), "1", "index of the other lead"),
        "intersection_lon": var(X, [r[2].where[0] for r in xrows], "degrees_east",
                                "longitude of the intersection"),
        "intersection_lat": var(X, [r[2].where[1] for r in xrows], "degrees_north",
                                "latitude of the intersection"),
    })
    if "broken_joints" in ds:
        data["broken_joint_leads_resolved"] = xr.Variable("time", resolved.astype(np.int8), {
            "long_name": "whether the broken-joint leads of this time are in the tables (0: "
            f"refused, the mask is wider than {MAX_CRACK_WIDTH:g} cells)",
            "flag_values": np.array([0, 1], np.int8), "flag_meanings": "refused resolved"})
    return xr.Dataset(data)
