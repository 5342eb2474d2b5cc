"""Element sources of bonded floes (Orzech et al.): one floe filled with small elements, and a field
of floes with a power-law size distribution.

A floe is an outline (rectangle, disc, ellipse or a convex ``[lon, lat]`` polygon) filled with a
random close packing of elements of mean size ``D``: Poisson-disc seeds (Bridson's algorithm,
``scipy.stats.qmc.PoissonDisk``) at a minimum spacing of ``0.78 D`` and their Voronoi cells
(``scipy.spatial.Voronoi``) clipped to the outline, so the mean element area is ``D²`` (the
packing gives ``1.64 r²`` per seed) and every pair of neighbours shares an edge exactly: with
``[contact] joints = "auto"`` each such pair is bonded. The geometry is built in the tangent plane
at the floe's centre (x east, y north, metres) and carried onto the sphere by the inverse
gnomonic projection, so floes may sit anywhere, the poles and the antimeridian included.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from siku_core import hookimpl
from siku_core.errors import SceneError
from siku_core.geometry.polygon import polygon_area
from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.params import Param

#: Poisson-disc spacing per element size: a Bridson packing holds one seed per 1.64 r²
SPACING = 1.0 / math.sqrt(1.64)
#: points on the outline of a disc or an ellipse per element size along it (at least 24)
ARC_POINTS_PER_D = 2.0


# --------------------------------------------------------------------------- planar geometry


def clip_convex(poly: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland–Hodgman: ``poly`` (convex, CCW) clipped by the convex CCW polygon ``clip``."""
    out = poly
    for k in range(len(clip)):
        if len(out) == 0:
            break
        a, b = clip[k], clip[(k + 1) % len(clip)]
        ex, ey = b - a
        side = ex * (out[:, 1] - a[1]) - ey * (out[:, 0] - a[0])  # > 0: inside (left)
        res = []
        n = len(out)
        for i in range(n):
            p, q = out[i], out[(i + 1) % n]
            sp, sq = side[i], side[(i + 1) % n]
            if sp >= 0:
                res.append(p)
            if (sp >= 0) != (sq >= 0):
                t = sp / (sp - sq)
                res.append(p + t * (q - p))
        out = np.array(res) if res else np.zeros((0, 2))
    return out


def tidy(poly: np.ndarray, tol: float) -> np.ndarray:
    """Drop vertices within ``tol`` [m] of the line through their two neighbours (coincident or
    collinear vertices), so that every edge of the polygon is a real edge."""
    p = list(poly)
    k = 0
    while len(p) >= 3 and k < len(p):
        a, b, c = p[k - 1], p[k], p[(k + 1) % len(p)]
        ac = c - a
        L = math.hypot(*ac)
        off = abs(ac[0] * (b - a)[1] - ac[1] * (b - a)[0]) / L if L > 0 else 0.0
        if off <= tol or math.hypot(*(b - a)) <= tol:
            del p[k]
            k = max(k - 1, 0)
        else:
            k += 1
    return np.array(p) if len(p) >= 3 else np.zeros((0, 2))


def outline_polygon(kind: str, length: float, width: float, angle: float,
                    element_size: float) -> np.ndarray:
    """The outline ``(k, 2)`` [m] about the origin, CCW: a ``length × width`` rectangle or
    ellipse (axes ``length``, ``width``, full lengths) or a disc of diameter ``length``, turned
    by ``angle`` [deg] counter-clockwise from east."""
    a, b = 0.5 * length, 0.5 * width
    if kind == "rectangle":
        p = np.array([[-a, -b], [a, -b], [a, b], [-a, b]])
    else:
        if kind == "disc":
            b = a
        perim = math.pi * (3 * (a + b) - math.sqrt((3 * a + b) * (a + 3 * b)))
        n = max(24, math.ceil(ARC_POINTS_PER_D * perim / element_size))
        t = 2 * math.pi * np.arange(n) / n
        p = np.column_stack([a * np.cos(t), b * np.sin(t)])
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    return p @ np.array([[c, s], [-s, c]])


def fill_outline(outline: np.ndarray, element_size: float, rng: np.random.Generator
                 ) -> list[np.ndarray]:
    """Voronoi cells [m] of Poisson-disc seeds inside the convex CCW ``outline``, clipped to it.

    Seeds are at least ``0.78 element_size`` apart; cells are convex, CCW, and neighbours share
    their common edge exactly. A floe smaller than one element is one element (the outline).
    """
    from scipy.spatial import Voronoi
    from scipy.stats import qmc

    lo = outline.min(axis=0)
    hi = outline.max(axis=0)
    side = float(max(hi - lo))
    r = SPACING * element_size
    if side <= 2 * r:
        return [outline.copy()]
    eng = qmc.PoissonDisk(2, radius=r / side, rng=rng)
    pts = lo + side * eng.fill_space()
    inside = np.ones(len(pts), dtype=bool)
    for k in range(len(outline)):
        a, b = outline[k], outline[(k + 1) % len(outline)]
        ex, ey = b - a
        inside &= ex * (pts[:, 1] - a[1]) - ey * (pts[:, 0] - a[0]) > 0
    pts = pts[inside]
    if len(pts) < 2:
        return [outline.copy()]
    centre = 0.5 * (lo + hi)
    t = 2 * math.pi * np.arange(32) / 32
    guard = centre + 3 * side * np.column_stack([np.cos(t), np.sin(t)])
    vor = Voronoi(np.vstack([pts, guard]))
    cells = []
    tol = 1e-7 * element_size
    for k in range(len(pts)):
        reg = vor.regions[vor.point_region[k]]
        if -1 in reg or not reg:  # pragma: no cover - the guard ring closes every inner cell
            continue
        v = vor.vertices[reg]
        ang = np.arctan2(v[:, 1] - pts[k, 1], v[:, 0] - pts[k, 0])
        v = v[np.argsort(ang)]
        c = tidy(clip_convex(v, outline), tol)
        if len(c) >= 3 and polygon_area(c) > 1e-6 * element_size**2:
            cells.append(c)
    return cells


# --------------------------------------------------------------------------- onto the sphere


def _frame(lon: float, lat: float) -> np.ndarray:
    """Columns: east, north and up unit vectors at ``(lon, lat)`` [deg]."""
    lo, la = math.radians(lon), math.radians(lat)
    east = np.array([-math.sin(lo), math.cos(lo), 0.0])
    north = np.array([-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo), math.cos(la)])
    up = np.array([math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)])
    return np.column_stack([east, north, up])


def to_lonlat(xy: np.ndarray, lon: float, lat: float, radius: float) -> np.ndarray:
    """Inverse gnomonic projection of tangent-plane points ``(k, 2)`` [m] at ``(lon, lat)``
    [deg] to ``[lon, lat]`` [deg] (longitudes in (-180, 180])."""
    g = _frame(lon, lat) @ np.column_stack([xy / radius, np.ones(len(xy))]).T
    g = g / np.linalg.norm(g, axis=0)
    return np.column_stack(xyz_to_lonlat(g.T))


def to_plane(lonlat: np.ndarray, lon: float, lat: float, radius: float) -> np.ndarray:
    """Gnomonic projection of ``[lon, lat]`` [deg] points into the tangent plane at
    ``(lon, lat)`` [m]."""
    loc = lonlat_to_xyz(lonlat[:, 0], lonlat[:, 1]) @ _frame(lon, lat)
    if np.any(loc[:, 2] <= 0.05):
        raise ValueError("outline spans too much of the sphere for one floe")
    return radius * loc[:, :2] / loc[:, 2:3]


def floe_cells(outline: np.ndarray, lon: float, lat: float, element_size: float,
               radius: float, rng: np.random.Generator) -> list[np.ndarray]:
    """The ``[lon, lat]`` polygons [deg] of a floe with planar ``outline`` [m] centred at
    ``(lon, lat)``."""
    return [to_lonlat(c, lon, lat, radius) for c in fill_outline(outline, element_size, rng)]


def _convex_ccw(p: np.ndarray, where: str) -> np.ndarray:
    if polygon_area(p) < 0:
        p = p[::-1]
    e = np.roll(p, -1, axis=0) - p
    cross = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    if np.any(cross < -1e-9 * float(np.abs(e).max()) ** 2):
        raise SceneError(f"{where}: the floe outline polygon must be convex (split a concave "
                         "floe into convex floes)")
    return p


# --------------------------------------------------------------------------- sources


class Floe(ElementSource):
    """One floe: an outline filled with bonded Voronoi elements of mean size ``D`` (as in
    Orzech et al.)."""

    name = "floe"
    params: ClassVar[dict[str, Param]] = {
        "outline": Param("rectangle", "", "shape of the floe", type=str,
                         choices=("rectangle", "disc", "ellipse", "polygon")),
        "center": Param([0.0, 0.0], "deg", "[lon, lat] of the floe centre (not for polygon)",
                        type=list),
        "length": Param(1000.0, "m", "rectangle/ellipse length along 'angle', disc diameter",
                        min=0),
        "width": Param(500.0, "m", "rectangle/ellipse width across 'angle'", min=0),
        "angle": Param(0.0, "deg", "direction of 'length', counter-clockwise from east"),
        "vertices": Param([], "deg", "[lon, lat] vertices of a convex outline (polygon)",
                          type=list),
        "element_size": Param(100.0, "m", "mean element size D (mean element area D²)",
                              min=1e-3),
        "seed": Param(-1, "1", "random seed of the packing (-1: the scene's [run] seed)",
                      type=int, min=-1),
        "max_elements": Param(2_000_000, "1", "refuse floes that would need more elements",
                              type=int, min=1),
    }

    def outline_at(self, where: str, radius: float) -> tuple[np.ndarray, float, float]:
        """The planar outline [m] and its centre ``(lon, lat)`` [deg]."""
        p = self.p
        if p["outline"] == "polygon":
            ll = np.array(p["vertices"], dtype=float)
            if ll.ndim != 2 or ll.shape[1] != 2 or len(ll) < 3:
                raise SceneError(f"{where}: outline = 'polygon' needs 'vertices', at least 3 "
                                 "[lon, lat] pairs")
            g = lonlat_to_xyz(ll[:, 0], ll[:, 1]).mean(axis=0)
            lon = math.degrees(math.atan2(g[1], g[0]))
            lat = math.degrees(math.atan2(g[2], math.hypot(g[0], g[1])))
            try:
                xy = to_plane(ll, lon, lat, radius)
            except ValueError as exc:
                raise SceneError(f"{where}: {exc}") from None
            return _convex_ccw(xy, where), lon, lat
        c = p["center"]
        if len(c) != 2 or not all(isinstance(v, (int, float)) for v in c) or abs(c[1]) > 90:
            raise SceneError(f"{where}: 'center' must be [lon, lat] in degrees")
        if p["length"] <= 0 or (p["outline"] != "disc" and p["width"] <= 0):
            raise SceneError(f"{where}: the floe needs a positive 'length' and 'width' [m]")
        return outline_polygon(p["outline"], p["length"], p["width"], p["angle"],
                               p["element_size"]), float(c[0]), float(c[1])

    def build(self, scene, seed, where):
        R = scene.cfg.planet.radius
        outline, lon, lat = self.outline_at(where, R)
        D = self.p["element_size"]
        n_est = abs(polygon_area(outline)) / D**2
        if n_est > self.p["max_elements"]:
            raise SceneError(f"{where}: about {n_est:.3g} elements of {D:g} m, above "
                             f"max_elements = {self.p['max_elements']}; raise element_size")
        if math.sqrt(abs(polygon_area(outline))) > 0.2 * R:
            raise SceneError(f"{where}: the floe is too large for the planet (its size should "
                             "be far below the radius)")
        cells = floe_cells(outline, lon, lat, D, R, np.random.default_rng(seed))
        return [ElementSpec(c, label=f"element {k}", floe=0) for k, c in enumerate(cells)]


class FloeField(ElementSource):
    """Many floes over a lon/lat box, sizes from a power law, placed without overlap."""

    name = "floe_field"
    params: ClassVar[dict[str, Param]] = {
        "lon": Param(None, "deg", "[west, east] of the region", type=list),
        "lat": Param(None, "deg", "[south, north] of the region", type=list),
        "shape": Param("rectangle", "", "floe shape (rectangles turned at random, or discs)",
                       type=str, choices=("rectangle", "disc")),
        "size_min": Param(200.0, "m", "smallest floe size (side or diameter)", min=1e-3),
        "size_max": Param(2000.0, "m", "largest floe size", min=1e-3),
        "exponent": Param(2.0, "1", "power-law exponent alpha: size density ~ size^-alpha",
                          min=0, max=10),
        "aspect": Param(1.0, "1", "rectangle width / length", min=0.05, max=1),
        "concentration": Param(0.5, "1", "target share of the region covered by floes",
                               min=0, max=0.9),
        "max_floes": Param(1000, "1", "at most this many floes", type=int, min=1,
                           max=1_000_000),
        "gap": Param(0.1, "1", "open water kept around each floe, share of its size", min=0,
                     max=10),
        "element_size": Param(50.0, "m", "mean element size D", min=1e-3),
        "seed": Param(-1, "1", "random seed (-1: the scene's [run] seed)", type=int, min=-1),
        "max_elements": Param(2_000_000, "1", "refuse fields that would need more elements",
                              type=int, min=1),
    }

    def sizes(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` sizes [m] from the density ``~ d^-alpha`` on ``[size_min, size_max]``
        (inverse transform of the truncated power law)."""
        p = self.p
        a, b, al = p["size_min"], p["size_max"], p["exponent"]
        u = rng.uniform(size=n)
        if abs(al - 1.0) < 1e-12:
            return a * (b / a) ** u
        e = 1.0 - al
        return (a**e + u * (b**e - a**e)) ** (1.0 / e)

    def layout(self, where: str, radius: float, seed: int
               ) -> list[tuple[float, float, float, float]]:
        """``(lon, lat, size, angle)`` of each placed floe, largest first."""
        p = self.p
        for key in ("lon", "lat"):
            v = p[key]
            if not (isinstance(v, list) and len(v) == 2
                    and all(isinstance(x, (int, float)) for x in v)):
                raise SceneError(f"{where}: '{key}' must be [low, high] in degrees")
        if p["size_max"] < p["size_min"]:
            raise SceneError(f"{where}: size_max = {p['size_max']:g} m is below size_min = "
                             f"{p['size_min']:g} m")
        lon0, lon1 = map(float, p["lon"])
        lat0, lat1 = map(float, p["lat"])
        if lon1 <= lon0:
            lon1 += 360.0
        if not -90 <= lat0 < lat1 <= 90:
            raise SceneError(f"{where}: lat = [south, north] needs -90 <= south < north <= 90")
        latm = math.radians(0.5 * (lat0 + lat1))
        W = radius * math.radians(lon1 - lon0) * math.cos(latm)
        H = radius * math.radians(lat1 - lat0)
        rng = np.random.default_rng(seed)
        target = p["concentration"] * W * H
        sizes = np.sort(self.sizes(rng, p["max_floes"]))[::-1]
        asp = p["aspect"] if p["shape"] == "rectangle" else 1.0
        placed: list[tuple[float, float, float, float]] = []
        xy: list[tuple[float, float, float]] = []  # x, y, bounding radius incl. gap [m]
        cover = 0.0
        for d in sizes:
            if cover >= target:
                break
            area = d * d * asp if p["shape"] == "rectangle" else math.pi * d * d / 4
            rb = 0.5 * d * math.hypot(1.0, asp) * (1.0 + p["gap"])
            if 2 * rb > min(W, H):
                continue
            for _ in range(200):
                x = rng.uniform(rb, W - rb)
                y = rng.uniform(rb, H - rb)
                if all((x - a) ** 2 + (y - b) ** 2 >= (rb + c) ** 2 for a, b, c in xy):
                    break
            else:
                continue
            ang = float(rng.uniform(0.0, 180.0))
            xy.append((x, y, rb))
            lat = lat0 + math.degrees(y / radius)
            lon = lon0 + math.degrees(x / (radius * math.cos(math.radians(lat))))
            placed.append((((lon + 180.0) % 360.0) - 180.0, lat, float(d), ang))
            cover += area
        return placed

    def build(self, scene, seed, where):
        R = scene.cfg.planet.radius
        p = self.p
        D = p["element_size"]
        floes = self.layout(where, R, seed)
        asp = p["aspect"] if p["shape"] == "rectangle" else 1.0
        n_est = sum(d * d * asp / D**2 for _, _, d, _ in floes)
        if n_est > p["max_elements"]:
            raise SceneError(f"{where}: about {n_est:.3g} elements of {D:g} m, above "
                             f"max_elements = {p['max_elements']}; raise element_size")
        rng = np.random.default_rng([seed, 1])
        out = []
        for f, (lon, lat, d, ang) in enumerate(floes):
            outline = outline_polygon(p["shape"], d, d * asp, ang, D)
            for k, c in enumerate(floe_cells(outline, lon, lat, D, R, rng)):
                out.append(ElementSpec(c, label=f"floe {f} element {k}", floe=f))
        return out


@hookimpl
def siku_register_element_sources():
    return [Floe, FloeField]
