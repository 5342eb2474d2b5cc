"""Deformation metrics with the RGPS method (``siku deformation --sirex``): Lagrangian cells,
coarse-graining with a coverage rule, spatial and temporal scaling of the moments, the
structure function, the rate distribution and its tail, and linear kinematic features.

The method follows the RGPS analyses of Marsan et al. (2004) and the Sea Ice Rheology
Experiment (SIREx: Bouchat et al. 2022, Hutter et al. 2022):

1. **Cells.** The centres of the free elements at the start of an interval ``T`` are
   triangulated (Delaunay); a triangle is a Lagrangian cell when its smallest angle is at least
   ``min_angle`` [deg] and its longest side at most ``max_side`` [m] (which drops the long thin
   triangles across bays and open water).
2. **Strain rates.** The velocity of a vertex is its displacement over ``T``; the velocity
   gradient of a cell is the line integral round it at the interval's mid positions
   (Green's theorem, exact for a field linear over the cell)::

       ux = (1/A) ∮ u dy,  uy = -(1/A) ∮ u dx,  vx = (1/A) ∮ v dy,  vy = -(1/A) ∮ v dx

   and ``eps = sqrt(div² + shear²)``, ``div = ux + vy``, ``shear = sqrt((ux - vy)² + (uy +
   vx)²)`` [1/s].
3. **Coarse-graining.** The plane is cut into ``L × L`` boxes; a box's gradient is the
   area-weighted mean of the gradients of the cells whose centroid it holds (boxes from the
   corner of the points' bounding box), kept when those cells cover at least ``coverage`` of
   the box. No scale below ``min_scale`` (the element
   size, or the cells') is reported: a box there holds a piece of one element.
4. **Scaling.** ``<eps^q>(L) ∝ L^-beta(q)`` at the shortest ``T`` for ``q`` = 0.5 … 3,
   ``beta(q)`` fitted by ``a q² + b q + c`` (convex, multifractal, when ``a > 0``); a field of
   isolated straight cracks gives ``beta(q) = q - 1`` (``a = 0``, ``b = 1``, ``c = -1``: a box
   holding the crack has ``eps ∝ 1/L`` and the share of boxes holding it grows as ``L``).
   ``<eps>(T) ∝ T^-alpha`` at the smallest ``L``.
5. **Distribution.** The cell rates at the shortest ``T``: the share above 0.01 /day, the
   share of the summed rate that the fastest 5 % of the cells carry (``top_share``: 0.05 when
   every cell deforms alike, near 1 when a few cells carry it all) and the log-spaced density.
6. **Linear kinematic features.** Cells deforming faster than ``lkf_rate`` joined through
   shared sides; a group of at least ``lkf_cells`` cells is one feature, its length the extent
   of its centroids along their principal axis, its orientation that axis's angle from east
   [deg, 0-180].

References: Marsan, D., Stern, H., Lindsay, R. and Weiss, J. (2004), Phys. Rev. Lett. 93,
178501; Bouchat, A., et al. (2022), J. Geophys. Res. Oceans 127, e2021JC017667; Hutter, N., et
al. (2022), J. Geophys. Res. Oceans 127, e2021JC017666.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .deformation_stats import DAY
from .lkf import detect, intersection_angles, lifetimes
#: the rate above which a cell counts in the distribution's tail [1/s] (0.01 /day)
TAIL_RATE = 0.01 / DAY
#: the moments of the structure function
QS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)


def cells(x: np.ndarray, y: np.ndarray, max_side: float | None = None,
          min_angle: float = 20.0) -> np.ndarray:
    """Lagrangian cells of points ``(x, y)`` [m]: ``(M, 3)`` vertex indices of the Delaunay
    triangles whose smallest angle is at least ``min_angle`` [deg] and longest side at most
    ``max_side`` [m] (default: twice the median side), counter-clockwise."""
    from scipy.spatial import Delaunay

    if len(x) < 3:
        return np.zeros((0, 3), np.int64)
    tri = Delaunay(np.column_stack([x, y])).simplices.astype(np.int64)
    px, py = x[tri], y[tri]
    sx = np.roll(px, -1, axis=1) - px
    sy = np.roll(py, -1, axis=1) - py
    side = np.hypot(sx, sy)
    if max_side is None:
        max_side = 2.0 * float(np.median(side))
    # angle at vertex k between the sides k -> k+1 and k -> k-1
    ax, ay = -np.roll(sx, 1, axis=1), -np.roll(sy, 1, axis=1)
    cosang = (sx * ax + sy * ay) / np.maximum(side * np.roll(side, 1, axis=1), 1e-300)
    ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    keep = (ang.min(axis=1) >= min_angle) & (side.max(axis=1) <= max_side)
    tri = tri[keep]
    px, py = x[tri], y[tri]
    area2 = ((px[:, 1] - px[:, 0]) * (py[:, 2] - py[:, 0])
             - (px[:, 2] - px[:, 0]) * (py[:, 1] - py[:, 0]))
    tri[area2 < 0] = tri[area2 < 0][:, ::-1]
    return tri


def cell_gradients(x0, y0, x1, y1, tri: np.ndarray, T: float):
    """Velocity gradients of the cells ``tri`` between positions ``(x0, y0)`` and ``(x1, y1)``
    [m] ``T`` [s] apart: ``(grad, area, cx, cy)`` with ``grad`` ``(M, 4)`` = ``ux, uy, vx, vy``
    [1/s] (line integral at the mid positions), ``area`` [m²] and centroids [m] there."""
    u, v = (x1 - x0) / T, (y1 - y0) / T
    xm, ym = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    X, Y, U, V = xm[tri], ym[tri], u[tri], v[tri]
    Xn, Yn, Un, Vn = (np.roll(a, -1, axis=1) for a in (X, Y, U, V))
    area = 0.5 * np.sum(X * Yn - Xn * Y, axis=1)
    dx, dy = Xn - X, Yn - Y
    um, vm = 0.5 * (U + Un), 0.5 * (V + Vn)
    with np.errstate(invalid="ignore", divide="ignore"):
        grad = np.column_stack([np.sum(um * dy, 1), -np.sum(um * dx, 1),
                                np.sum(vm * dy, 1), -np.sum(vm * dx, 1)]) / area[:, None]
    return grad, area, X.mean(axis=1), Y.mean(axis=1)


def total_rate(grad: np.ndarray) -> np.ndarray:
    """``eps = sqrt(div² + shear²)`` [1/s] of gradients ``(…, 4)`` = ``ux, uy, vx, vy``."""
    ux, uy, vx, vy = (grad[..., k] for k in range(4))
    return np.hypot(ux + vy, np.hypot(ux - vy, uy + vx))


def coarse_grain(cx, cy, area, grad, L: float, coverage: float = 0.5,
                 origin: tuple[float, float] | None = None) -> np.ndarray:
    """Total deformation rate [1/s] of every ``L × L`` box (from ``origin``, default the least
    centroid) whose cells (by centroid) cover at least ``coverage`` of it: the area-weighted
    mean of their gradients."""
    ok = np.isfinite(grad).all(axis=1) & (area > 0)
    cx, cy, area, grad = cx[ok], cy[ok], area[ok], grad[ok]
    if not len(area):
        return np.zeros(0)
    x0, y0 = (cx.min(), cy.min()) if origin is None else origin
    ix = np.floor((cx - x0) / L).astype(np.int64)
    iy = np.floor((cy - y0) / L).astype(np.int64)
    ix -= ix.min()
    iy -= iy.min()
    key = iy * (int(ix.max()) + 1) + ix
    _, inv = np.unique(key, return_inverse=True)
    A = np.bincount(inv, weights=area)
    G = np.column_stack([np.bincount(inv, weights=area * grad[:, k]) for k in range(4)])
    keep = A >= coverage * L * L
    return total_rate(G[keep] / A[keep, None])


def fit_slope(scales, values) -> tuple[float, float]:
    """``(b, standard error)`` of ``values ∝ scales^-b`` by least squares in log-log over the
    finite positive values (NaN with fewer than two)."""
    s, m = np.asarray(scales, float), np.asarray(values, float)
    ok = np.isfinite(m) & (m > 0)
    s, m = np.log(s[ok]), np.log(m[ok])
    if len(s) < 2:
        return np.nan, np.nan
    c = np.polyfit(s, m, 1)
    se = 0.0
    if len(s) > 2:
        r = m - np.polyval(c, s)
        se = float(np.sqrt(r @ r / (len(s) - 2) / np.sum((s - s.mean()) ** 2)))
    return float(-c[0]), se


def structure_fit(qs, beta) -> tuple[float, float, float]:
    """``(a, b, c)`` of ``beta(q) = a q² + b q + c`` by least squares. A field deforming
    everywhere has ``c = 0`` (``<eps^0> = 1``); one whose deforming boxes fill a share
    ``∝ L^-c`` of the plane (a crack: ``c = -1``) has ``c`` that share's exponent."""
    q, b = np.asarray(qs, float), np.asarray(beta, float)
    ok = np.isfinite(b)
    if ok.sum() < 3:
        return np.nan, np.nan, np.nan
    a, bb, c = np.polyfit(q[ok], b[ok], 2)
    return float(a), float(bb), float(c)


def features(tri: np.ndarray, eps: np.ndarray, cx, cy, rate: float, min_cells: int = 3):
    """Linear kinematic features (:func:`siku_io.analysis.lkf.detect`: cells faster than
    ``rate`` [1/s], split at junctions), at least ``min_cells`` cells each: ``(lengths [m],
    orientations [deg from east, 0-180])``."""
    fs = detect(tri, eps, cx, cy, rate, min_cells)
    return (np.array([f.length for f in fs]), np.array([f.angle for f in fs]))


@dataclass
class SirexStats:
    """``moments[q][iT, iL]``: ``<eps^q>`` [(1/s)^q] over the boxes of scale ``scales[iL]``
    [m] and interval ``times[iT]`` [s]; ``counts`` boxes; ``beta_q[q]`` (± ``beta_q_se``) the
    spatial exponents at the shortest interval and ``(a, b, c)`` their quadratic fit; ``alpha``
    (± ``alpha_se``) the temporal exponent of ``<eps>`` at the smallest scale; ``rates`` the
    cell rates [1/s] at the shortest interval; ``lkf_lengths`` [m], ``lkf_angles`` [deg] and
    ``lkf_counts`` per interval, ``lkf_intersections`` [deg, 0-90] and ``lkf_lifetimes`` [s]
    (:mod:`siku_io.analysis.lkf`); ``cell_size`` [m] the median cell's square-root area;
    ``dropped`` the scales below ``min_scale`` not reported."""

    scales: np.ndarray
    times: np.ndarray
    moments: dict[float, np.ndarray]
    counts: np.ndarray
    beta_q: dict[float, float]
    beta_q_se: dict[float, float]
    a: float
    b: float
    c: float
    alpha: float
    alpha_se: float
    rates: np.ndarray
    cell_size: float
    lkf_lengths: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lkf_angles: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lkf_counts: list = field(default_factory=list)
    dropped: list = field(default_factory=list)
    lkf_intersections: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lkf_lifetimes: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def tail(self) -> float:
        """Share of the cell rates above 0.01 /day."""
        return float(np.mean(self.rates > TAIL_RATE)) if len(self.rates) else np.nan

    def top_share(self, fraction: float = 0.05) -> float:
        """Share of the summed cell rate carried by the fastest ``fraction`` of the cells
        (``fraction`` itself when every cell deforms at the same rate)."""
        r = np.sort(self.rates)[::-1]
        total = float(np.sum(r))
        if not len(r) or total <= 0.0:
            return np.nan
        return float(np.sum(r[:max(1, int(round(fraction * len(r))))]) / total)

    def histogram(self, bins: int = 24) -> tuple[np.ndarray, np.ndarray]:
        """Probability density of the cell rates on log-spaced bins [1/day]: ``(density,
        edges)``."""
        r = self.rates[self.rates > 0] * DAY
        if not len(r):
            return np.zeros(0), np.zeros(0)
        lo, hi = r.min(), r.max()
        hi = hi if hi > lo * (1 + 1e-9) else lo * 10.0  # one value: a decade above it
        edges = np.logspace(np.log10(lo), np.log10(hi), bins + 1)
        return np.histogram(r, edges, density=True)[0], edges

    def table(self) -> str:
        """A plain-text report beside the RGPS values (``RGPS``)."""
        out = [f"cells: median size {self.cell_size / 1e3:.1f} km, "
               f"{len(self.rates)} cell rates at T = {self.times[0] / 3600:g} h"]
        if self.dropped:
            out.append("not reported (below the element or cell size): "
                       + ", ".join(f"{L / 1e3:g}" for L in self.dropped) + " km")
        out.append("<eps> [1/day]  T [h] \\ L [km] "
                   + " ".join(f"{L / 1e3:8g}" for L in self.scales))
        for i, T in enumerate(self.times):
            out.append(f"{T / 3600:29g} " + " ".join(
                f"{m * DAY:8.4f}" for m in self.moments[1.0][i]))
        out.append("boxes (T = %g h): " % (self.times[0] / 3600)
                   + " ".join(str(int(c)) for c in self.counts[0]))
        for q in self.beta_q:
            out.append(f"beta(q = {q:g}) = {self.beta_q[q]:.3f} ± "
                       f"{1.96 * self.beta_q_se[q]:.3f}   (q - 1 = {q - 1:g})")
        out.append(f"beta(q) = a q² + b q + c: a = {self.a:.3f}, b = {self.b:.3f}, "
                   f"c = {self.c:.3f} (convex when a > 0; q - 1 is a = 0, b = 1, c = -1)")
        out.append(f"alpha (L = {self.scales[0] / 1e3:g} km) = {self.alpha:.3f} ± "
                   f"{1.96 * self.alpha_se:.3f}")
        out.append(f"share of cell rates above 0.01 /day: {self.tail:.1%}; the fastest 5 % "
                   f"of the cells carry {self.top_share():.0%} of the summed rate")
        if len(self.lkf_lengths):
            out.append(f"linear kinematic features: {len(self.lkf_lengths)} over "
                       f"{len(self.lkf_counts)} intervals, median length "
                       f"{np.median(self.lkf_lengths) / 1e3:.0f} km, orientation spread "
                       f"{_axial_spread(self.lkf_angles):.0f} deg")
            if len(self.lkf_intersections):
                out.append(f"  intersections: {len(self.lkf_intersections)}, median angle "
                           f"{np.median(self.lkf_intersections):.0f} deg")
            if len(self.lkf_lifetimes):
                out.append(f"  tracks: {len(self.lkf_lifetimes)}, median lifetime "
                           f"{np.median(self.lkf_lifetimes) / 3600:g} h, longest "
                           f"{self.lkf_lifetimes.max() / 3600:g} h")
        out.append("RGPS (winter): " + RGPS_LINE)
        return "\n".join(out)


#: the published RGPS values printed beside a result (see docs/explanation/deformation.md)
RGPS_LINE = ("beta(1) about 0.1-0.2 (daily to 3-day, 10-1000 km; Marsan et al. 2004), "
             "beta(q) convex in q; share above 0.01 /day about 40 %")


def _axial_spread(deg: np.ndarray) -> float:
    """Circular standard deviation [deg] of axial angles (period 180 deg)."""
    z = min(float(np.abs(np.mean(np.exp(2j * np.radians(deg))))), 1.0)
    return abs(float(np.degrees(np.sqrt(-2.0 * np.log(max(z, 1e-12))) / 2.0)))


def sirex(positions, dt: float, scales, steps=(1,), coverage: float = 0.5,
          min_scale: float = 0.0, max_side: float | None = None, min_angle: float = 20.0,
          lkf_rate: float = 0.05 / DAY, qs=QS) -> SirexStats:
    """The metrics of the module docstring from ``positions[k] = (x, y)`` [m] of the same
    points at snapshots ``dt`` [s] apart, over length ``scales`` [m] (those below
    ``min_scale`` [m] or the median cell's size are dropped) and intervals ``steps`` (whole
    snapshot intervals; each pair of snapshots ``n`` apart that fits is one sample)."""
    steps = sorted(int(s) for s in steps)
    scales = np.asarray(sorted(scales), float)
    x0, y0 = positions[0]
    tri0 = cells(x0, y0, max_side, min_angle)
    if not len(tri0):
        from siku_core import DataError

        raise DataError("deformation metrics: no Lagrangian cell passes the shape filter")
    px, py = x0[tri0], y0[tri0]
    cell_size = float(np.median(np.sqrt(0.5 * np.abs(
        (px[:, 1] - px[:, 0]) * (py[:, 2] - py[:, 0])
        - (px[:, 2] - px[:, 0]) * (py[:, 1] - py[:, 0])))))
    floor = max(min_scale, cell_size)
    dropped = [float(L) for L in scales if L < floor]
    scales = scales[scales >= floor]
    if not len(scales):
        from siku_core import DataError

        raise DataError(f"deformation metrics: every scale is below the element or cell size "
                        f"({floor / 1e3:.1f} km)")
    nT, nL = len(steps), len(scales)
    sums = {q: np.zeros((nT, nL)) for q in qs}
    counts = np.zeros((nT, nL), np.int64)
    rates, lengths, angles, nlkf, crossings, tracked = [], [], [], [], [], []
    for iT, n in enumerate(steps):
        for k in range(0, len(positions) - n, n):
            (xa, ya), (xb, yb) = positions[k], positions[k + n]
            tri = cells(xa, ya, max_side, min_angle)
            grad, area, cx, cy = cell_gradients(xa, ya, xb, yb, tri, n * dt)
            corner = (float(np.min(0.5 * (xa + xb))), float(np.min(0.5 * (ya + yb))))
            for iL, L in enumerate(scales):
                r = coarse_grain(cx, cy, area, grad, L, coverage, corner)
                for q in qs:
                    sums[q][iT, iL] += np.sum(r ** q)
                counts[iT, iL] += len(r)
            if iT == 0:
                eps = total_rate(grad)
                good = np.isfinite(eps)
                rates.append(eps[good])
                fs = detect(tri[good], eps[good], cx[good], cy[good], lkf_rate)
                lengths.append(np.array([f.length for f in fs]))
                angles.append(np.array([f.angle for f in fs]))
                nlkf.append(len(fs))
                crossings.append(intersection_angles(fs, 3.0 * cell_size))
                tracked.append(fs)
    with np.errstate(invalid="ignore", divide="ignore"):
        moments = {q: s / counts for q, s in sums.items()}
    times = np.asarray(steps, float) * dt
    bq, bse = {}, {}
    for q in qs:
        bq[q], bse[q] = fit_slope(scales, moments[q][0])
    a, b, c = structure_fit(list(bq), list(bq.values()))
    alpha, alpha_se = (fit_slope(times, moments[1.0][:, 0]) if nT > 1 and 1.0 in moments
                       else (np.nan, np.nan))
    return SirexStats(scales, times, moments, counts, bq, bse, a, b, c, alpha, alpha_se,
                      np.concatenate(rates) if rates else np.zeros(0), cell_size,
                      np.concatenate(lengths) if lengths else np.zeros(0),
                      np.concatenate(angles) if angles else np.zeros(0), nlkf, dropped,
                      np.concatenate(crossings) if crossings else np.zeros(0),
                      lifetimes(tracked, steps[0] * dt))


def window_snapshots(seconds, window, where="output") -> np.ndarray:
    """Indices of the snapshots at ``seconds`` [s] that fall in ``window = (t0, t1)`` [s after
    the first snapshot, both ends included to a microsecond]; at least two, or a
    :class:`~siku_core.DataError` naming ``where``."""
    rel = np.asarray(seconds, float) - float(seconds[0])
    keep = np.flatnonzero((rel >= window[0] - 1e-6) & (rel <= window[1] + 1e-6))
    if len(keep) < 2:
        from siku_core import DataError

        raise DataError(f"{where}: the window {window[0] / 3600:g}-{window[1] / 3600:g} h "
                        f"holds {len(keep)} snapshot(s); the metrics need two")
    return keep


def output_sirex(path, scales, steps=(1,), coverage: float = 0.5, window=None,
                 **kw) -> SirexStats:
    """:func:`sirex` of the free elements of a run's output file, no scale below the median
    element's size (square root of its area); ``window = (t0, t1)`` [s from the first
    snapshot] keeps the snapshots from ``t0`` to ``t1`` (both included) only."""
    from siku_io.analysis.deformation_stats import plane_positions
    from siku_io.analysis.gridded_fields import snapshot_seconds
    from siku_io.output.xr import open_output

    ds = open_output(path)
    R = float(ds.attrs["radius"])
    seconds = np.asarray(snapshot_seconds(ds), float)
    dts = np.diff(seconds)
    if len(dts) == 0 or not np.allclose(dts, dts[0], rtol=1e-9):
        from siku_core import DataError

        raise DataError(f"{path}: deformation metrics need at least two snapshots at a "
                        "constant interval")
    lon, lat = ds["lon"].values, ds["lat"].values
    if window is not None:
        keep = window_snapshots(seconds, window, path)
        lon, lat = lon[keep], lat[keep]
    # flags and areas are per snapshot in a run whose processes may change them: the elements
    # free in every snapshot kept, their areas at the first
    flags = ds["flags"].values if "flags" in ds else np.zeros(lon.shape[-1], int)
    free = np.all(np.atleast_2d(flags if flags.ndim == 1 or window is None else flags[keep])
                  == 0, axis=0)
    area = np.atleast_2d(ds["area"].values)[0] if "area" in ds else None
    element = float(np.sqrt(np.median(area[free]))) if area is not None else 0.0
    lon0 = float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(lon[0][free]))))))
    lat0 = float(np.mean(lat[0][free]))
    pos = [plane_positions(lon[k][free], lat[k][free], lon0, lat0, R) for k in range(len(lon))]
    kw.setdefault("min_scale", element)
    return sirex(pos, float(dts[0]), scales, steps, coverage, **kw)


def plot_sirex(stats: SirexStats, target, label: str = "siku") -> None:
    """``beta(q)`` with its quadratic fit beside ``q - 1`` (isolated cracks) and 0
    (homogeneous strain), and the log-spaced density of the cell rates [1/day] with the
    0.01 /day threshold, side by side, saved to ``target`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    q = np.array(list(stats.beta_q))
    b = np.array([stats.beta_q[k] for k in q])
    e = np.array([1.96 * stats.beta_q_se[k] for k in q])
    a1.errorbar(q, b, yerr=e, fmt="o", label=f"{label} (95 %)")
    qq = np.linspace(0.0, q.max(), 50)
    a1.plot(qq, stats.a * qq**2 + stats.b * qq + stats.c, "-",
            label=f"fit a = {stats.a:.2f}, b = {stats.b:.2f}, c = {stats.c:.2f}")
    a1.plot(qq, qq - 1.0, "k:", label="q - 1 (isolated straight cracks)")
    a1.axhline(0.0, color="0.6", lw=0.8)
    a1.set_xlabel("moment q")
    a1.set_ylabel("beta(q)")
    a1.set_title(f"spatial scaling over {stats.scales[0] / 1e3:g}-{stats.scales[-1] / 1e3:g} km")
    a1.legend(fontsize=8)
    dens, edges = stats.histogram()
    if len(dens):
        mid = np.sqrt(edges[:-1] * edges[1:])
        ok = dens > 0
        a2.loglog(mid[ok], dens[ok], "o-", label=f"{label}: {stats.tail:.1%} above 0.01 /day")
    a2.axvline(0.01, color="k", ls=":", label="0.01 /day")
    a2.set_xlabel("total deformation rate of a cell [1/day]")
    a2.set_ylabel("probability density [day]")
    a2.set_title(f"cells of {stats.cell_size / 1e3:.0f} km, T = {stats.times[0] / 3600:g} h")
    a2.legend(fontsize=8)
    fig.tight_layout()
    from siku_io.plot.mapdeco import save_png

    save_png(fig, target, dpi=110)
    plt.close(fig)
