"""Floe size distribution (``siku fsd``): the floes of each snapshot, their areas and mean
calipers, the distribution on logarithmic area bins and the power-law exponent of the areas.

* **Floes**: the connected groups of elements over intact joints (the same rule as
  ``ctx.contacts.floe_labels``); an element without intact joints is a
  floe of its own. Labels come from ``scipy.sparse.csgraph.connected_components`` on the joint
  table; the joint pairs of a run are rebuilt from the scene stored in its output file (they are
  fixed for a run, unless a process creates joints: then each snapshot's pairs are read from
  ``/states/history/contacts/pairs``), their intact flags at each snapshot are read from the
  contact model's history (``/states/history/contacts/intact``).
* **Free floes**: a floe holding a static or steady element (a coast cell, landfast ice) is
  not a floe of the drifting ice; the distribution and its power law are those of the free
  floes unless asked for all (``siku fsd --all-elements``).
* **Area** of a floe ``A = Σ a_e`` [m²], the sum of its elements' areas.
* **Mean caliper** ``d = P_hull / π`` [m]: the mean over directions of the floe's width, which
  by Cauchy's formula is the perimeter of its convex hull over π (a disc of diameter ``D`` gives
  ``D``, a square of side ``s`` gives ``4 s / π``). The hull is taken of the floe's element
  vertices in the plane tangent to the sphere at the floe's centre.
* **Distribution**: floe counts on logarithmic area bins and the probability density
  ``p(A) = n_bin / (N ΔA_bin)`` [m⁻²].
* **Power law** ``p(A) = (α − 1)/A_min (A/A_min)^(−α)`` for ``A ≥ A_min`` by maximum
  likelihood (Clauset, Shalizi & Newman 2009, SIAM Review 51, 661–703, eqs. 3.1, 3.2 and
  section 3.3): ``α̂ = 1 + n [Σ ln(A_i/A_min)]⁻¹``, standard error ``(α̂ − 1)/√n``, and
  ``A_min`` the candidate (each distinct area leaving at least ``min_tail`` floes above it)
  that minimises the Kolmogorov–Smirnov distance between the tail's empirical distribution and
  the fitted one. ``α`` is the exponent of the density of areas; the cumulative number of floes
  larger than ``A`` falls as ``A^(1 − α)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from siku_core import DataError
from siku_core.deprecation import moved_names

#: fewest floes in the tail for a power-law fit
MIN_TAIL = 10
#: fewest non-empty area bins the tail must span for a power-law fit
MIN_BINS = 3


# ------------------------------------------------------------------------------- floes
def floe_labels(n: int, ji, jj, intact) -> tuple[int, np.ndarray]:
    """Floes of ``n`` elements joined by joints ``(ji[k], jj[k])`` where ``intact[k]``:
    ``(count, label)``, ``label[element]`` in ``0..count-1``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    k = np.asarray(intact, bool)
    ji, jj = np.asarray(ji, np.int64)[k], np.asarray(jj, np.int64)[k]
    g = coo_matrix((np.ones(len(ji)), (ji, jj)), shape=(n, n))
    count, label = connected_components(g, directed=False)
    return int(count), label.astype(np.int64)


def free_floes(label, count: int, flags) -> np.ndarray:
    """Per floe: whether every element of it is free (``flags == FREE``; a floe holding a
    static or steady element is held to the coast)."""
    held = np.bincount(label, (np.asarray(flags) != 0).astype(float), count)
    return held == 0


def floe_areas(label, count: int, area) -> np.ndarray:
    """Area of each floe [m²]: the sum of its elements' ``area`` [m²]."""
    return np.bincount(label, np.asarray(area, float), count)


def mean_calipers(label, count: int, node_lon, node_lat, offsets, radius: float) -> np.ndarray:
    """Mean caliper diameter of each floe [m]: the perimeter of the convex hull of its element
    vertices (``node_lon``, ``node_lat`` [deg], CSR ``offsets`` per element) in the plane
    tangent at the floe's mean vertex direction, over π (Cauchy's formula), on a sphere of
    ``radius`` [m]."""
    from scipy.spatial import ConvexHull, QhullError

    lon, lat = np.radians(node_lon), np.radians(node_lat)
    xyz = np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    counts = np.diff(np.asarray(offsets, np.int64))
    owner = np.repeat(np.asarray(label, np.int64), counts)
    order = np.argsort(owner, kind="stable")
    bounds = np.searchsorted(owner[order], np.arange(count + 1))
    out = np.zeros(count)
    for f in range(count):
        p = xyz[order[bounds[f]:bounds[f + 1]]]
        c = p.mean(axis=0)
        c /= np.linalg.norm(c)
        e = np.cross([0.0, 0.0, 1.0], c)
        if np.linalg.norm(e) < 1e-12:  # at a pole
            e = np.array([1.0, 0.0, 0.0])
        e /= np.linalg.norm(e)
        nvec = np.cross(c, e)
        # gnomonic projection onto the tangent plane at c [m]
        dot = p @ c
        xy = radius * np.column_stack([p @ e, p @ nvec]) / dot[:, None]
        try:
            hull = ConvexHull(xy)
        except QhullError:  # degenerate (collinear vertices): twice the longest extent
            out[f] = 2.0 * np.ptp(xy, axis=0).max() / np.pi
            continue
        v = xy[hull.vertices]
        out[f] = np.sum(np.hypot(*(np.roll(v, -1, axis=0) - v).T)) / np.pi
    return out


# --------------------------------------------------------------------------- power law
@dataclass
class PowerLaw:
    """A continuous power law fitted to a sample: density exponent ``alpha`` [1] with standard
    error ``alpha_se`` [1], lower cut-off ``xmin`` (units of the sample), ``n_tail`` values at
    or above it, Kolmogorov–Smirnov distance ``ks`` [1] of the fit."""

    alpha: float
    alpha_se: float
    xmin: float
    n_tail: int
    ks: float


def fit_alpha(x, xmin: float) -> tuple[float, float, int]:
    """Maximum-likelihood exponent of a continuous power law above ``xmin`` (Clauset et al.
    2009, eqs. 3.1 and 3.2): ``(alpha, standard error, n)``."""
    t = np.asarray(x, float)
    t = t[t >= xmin]
    n = len(t)
    s = np.sum(np.log(t / xmin))
    if n == 0 or not s > 0:
        return np.nan, np.nan, n
    a = 1.0 + n / s
    return a, (a - 1.0) / np.sqrt(n), n


def power_law(x, min_tail: int = MIN_TAIL) -> PowerLaw:
    """The power law of a positive sample ``x`` with its lower cut-off by the
    Kolmogorov–Smirnov rule (Clauset et al. 2009, section 3.3): every distinct value leaving at
    least ``min_tail`` values at or above it is tried, and the one whose fitted law is closest
    (KS distance) to the tail's empirical distribution is kept. NaN fields when the sample has
    fewer than ``min_tail`` values."""
    xs = np.sort(np.asarray(x, float))
    xs = xs[xs > 0]
    n = len(xs)
    if n < max(min_tail, 2):
        return PowerLaw(np.nan, np.nan, np.nan, n, np.nan)
    logs = np.log(xs)
    # suffix sums of log x: the tail from index i holds xs[i:], n - i values
    tail_log = np.cumsum(logs[::-1])[::-1]
    # first index of each distinct value (values within 1e-9 relative are one: element areas
    # summed in another order differ in the last bits), leaving a tail that is not all one value
    starts = np.flatnonzero(np.r_[True, np.diff(xs) > 1e-9 * xs[1:]])
    starts = starts[(n - starts >= min_tail) & (xs[-1] > xs[starts] * (1 + 1e-9))]
    best = PowerLaw(np.nan, np.nan, np.nan, 0, np.inf)
    for i in starts:
        m = n - i
        s = tail_log[i] - m * logs[i]
        if not s > 0:
            continue
        a = 1.0 + m / s
        t = xs[i:]
        cdf = 1.0 - (t / xs[i]) ** (1.0 - a)
        emp_hi = np.arange(1, m + 1) / m
        emp_lo = np.arange(0, m) / m
        d = max(np.max(np.abs(emp_hi - cdf)), np.max(np.abs(cdf - emp_lo)))
        if d < best.ks:
            best = PowerLaw(a, (a - 1.0) / np.sqrt(m), float(xs[i]), int(m), float(d))
    return best


def tail_fit(x, min_tail: int = MIN_TAIL, edges=None, per_decade: int = 5) -> PowerLaw:
    """The power law of the areas ``x`` [m²] (:func:`power_law`), or :class:`DataError` in
    one line when the data cannot carry one: fewer than ``min_tail`` floes above any cut-off,
    or a tail whose floes lie in fewer than :data:`MIN_BINS` of the area bins ``edges`` (by
    default :func:`log_bins` of ``x`` with ``per_decade`` bins a decade): an exponent needs a
    range of sizes to be told from the data."""
    xs = np.asarray(x, float)
    xs = xs[xs > 0]
    fit = power_law(xs, min_tail)
    if not np.isfinite(fit.alpha):
        raise DataError(f"{len(xs)} floes: a power law needs at least {max(min_tail, 2)} above "
                        "its cut-off, of more than one area; none fitted")
    if edges is None:
        edges = log_bins(xs.min(), xs.max(), per_decade)
    bins = np.count_nonzero(np.histogram(xs[xs >= fit.xmin], np.asarray(edges, float))[0])
    if bins < MIN_BINS:
        raise DataError(f"{fit.n_tail} floes above {fit.xmin:.4g} m2 lie in {bins} area "
                        f"bin(s): a power law needs a tail over at least {MIN_BINS}; none "
                        "fitted")
    return fit


# ------------------------------------------------------------------------ distribution
def log_bins(lo: float, hi: float, per_decade: int = 5) -> np.ndarray:
    """Logarithmic bin edges [units of lo, hi] covering ``[lo, hi]`` with ``per_decade`` bins
    per decade, aligned on powers of ten."""
    a = np.floor(np.log10(lo) * per_decade) / per_decade
    b = np.ceil(np.log10(hi) * per_decade) / per_decade
    if b <= a:
        b = a + 1.0 / per_decade
    k = int(round((b - a) * per_decade))
    return 10.0 ** np.linspace(a, b, k + 1)


def distribution(areas_per_time: list[np.ndarray], times, edges=None, per_decade: int = 5,
                 min_tail: int = MIN_TAIL, calipers_per_time=None):
    """The floe size distribution as an ``xarray.Dataset``: per ``time`` the number of floes,
    the count and density of floe areas on logarithmic bins (dimension ``area_bin``) and the
    fitted power law (``alpha``, ``alpha_se``, ``area_min``, ``n_tail``, ``ks``), NaN where
    fewer than ``min_tail`` floes or ``MIN_BINS`` non-empty bins would carry it."""
    import xarray as xr

    allv = np.concatenate([a[a > 0] for a in areas_per_time]) if areas_per_time else np.ones(1)
    if edges is None:
        edges = log_bins(allv.min(), allv.max(), per_decade)
    edges = np.asarray(edges, float)
    nt, nb = len(areas_per_time), len(edges) - 1
    count = np.zeros((nt, nb))
    fits = []
    for t, a in enumerate(areas_per_time):
        count[t] = np.histogram(a, edges)[0]
        try:
            fit = tail_fit(a, min_tail, edges)
        except DataError:   # too few floes or bins: no exponent (NaN), the table says why
            fit = PowerLaw(np.nan, np.nan, np.nan, power_law(a, min_tail).n_tail, np.nan)
        fits.append(fit)
    nfl = np.array([len(a) for a in areas_per_time], float)
    width = np.diff(edges)
    pdf = count / np.where(nfl > 0, nfl, 1.0)[:, None] / width[None, :]
    data = {
        "n_floes": xr.Variable("time", nfl.astype(np.int64), {
            "units": "1", "long_name": "floes (groups of elements over intact joints)"}),
        "count": xr.Variable(("time", "area_bin"), count.astype(np.int64), {
            "units": "1", "long_name": "floes with their area in the bin"}),
        "pdf": xr.Variable(("time", "area_bin"), pdf, {
            "units": "m-2", "long_name": "probability density of floe area"}),
        "alpha": xr.Variable("time", [f.alpha for f in fits], {
            "units": "1", "long_name": "power-law exponent of the density of floe areas, "
            "p(A) ~ A^-alpha, maximum likelihood (Clauset et al. 2009)"}),
        "alpha_se": xr.Variable("time", [f.alpha_se for f in fits], {
            "units": "1", "long_name": "standard error of alpha, (alpha - 1)/sqrt(n_tail)"}),
        "area_min": xr.Variable("time", [f.xmin for f in fits], {
            "units": "m2", "long_name": "lower cut-off of the power law (Kolmogorov-Smirnov "
            "rule)"}),
        "n_tail": xr.Variable("time", [f.n_tail for f in fits], {
            "units": "1", "long_name": "floes at or above area_min"}),
        "ks": xr.Variable("time", [f.ks for f in fits], {
            "units": "1", "long_name": "Kolmogorov-Smirnov distance of the fit"}),
        "area_bin_lower": xr.Variable("area_bin", edges[:-1], {
            "units": "m2", "long_name": "lower edge of the area bin"}),
        "area_bin_upper": xr.Variable("area_bin", edges[1:], {
            "units": "m2", "long_name": "upper edge of the area bin"}),
    }
    if calipers_per_time is not None:
        data["mean_caliper_mean"] = xr.Variable(
            "time", [float(np.mean(c)) if len(c) else np.nan for c in calipers_per_time],
            {"units": "m", "long_name": "mean over the floes of their mean caliper diameter"})
    coords = {"time": xr.Variable("time", np.asarray(times, float), {
                  "units": "s", "long_name": "model time of the snapshot"}),
              "area_bin": xr.Variable("area_bin", np.sqrt(edges[:-1] * edges[1:]), {
                  "units": "m2", "long_name": "geometric centre of the area bin"})}
    ds = xr.Dataset(data, coords)
    ds.attrs.update({"title": "floe size distribution", "references": (
        "Clauset, Shalizi & Newman (2009), SIAM Review 51, 661-703 (power-law fit)")})
    return ds


# ---------------------------------------------------------------------------- from files
@dataclass
class Floes:
    """The floes of one snapshot: ``label`` per element, ``area`` [m²], ``caliper`` [m] and
    ``free`` (no static or steady element) per floe, at model ``time`` [s]."""

    time: float
    label: np.ndarray
    area: np.ndarray
    caliper: np.ndarray
    free: np.ndarray


def joint_table(path) -> tuple[np.ndarray, np.ndarray]:
    """The joint pairs ``(ji, jj)`` of the run that wrote output file ``path``: the scene it
    stores is built again (without running or writing) and its contact model's joints taken."""
    from pathlib import Path

    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_io.output.results import open_results

    with open_results(path) as f:
        text = f["scene"][()]
        text = text.decode() if isinstance(text, bytes) else str(text)
        where = str(f.attrs.get("scene_file", ""))
        nj = f["states/history/contacts/intact"].shape[1] if \
            "states/history/contacts/intact" in f else 0
    scene = scene_from_text(text, f"{path}: its scene", Path(where) if where else None)
    sim = Simulation(scene, out=False, progress=False)
    cm = sim.context.contacts
    n = cm.joint_slots if cm is not None else 0
    if n != nj:
        raise DataError(f"{path}: its scene builds {n} joints but the file records {nj}")
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.array(cm.ji, np.int64), np.array(cm.jj, np.int64)  # (copies, writable)


def output_floes(path, calipers: bool = True):
    """:class:`Floes` of every snapshot of output file ``path``."""
    from siku_io.output.results import open_results

    ji, jj = joint_table(path)
    with open_results(path) as f:
        n_t = len(f["states/step"])
        times = f["states/time"][:n_t]
        area = f["geometry/area"][()]
        flags = f["geometry/flags"][()] if "geometry/flags" in f else np.zeros(len(area))
        radius = float(f.attrs["radius"])
        off = f["geometry/vert_offsets"][()]
        key = "states/history/contacts/intact"
        intact = f[key][:n_t].astype(bool) if key in f else np.zeros((n_t, 0), bool)
        # a run whose processes create joints records every snapshot's joint pairs
        key = "states/history/contacts/pairs"
        pairs = f[key][:n_t] if key in f else None
        q = f["states/q"][:n_t]
        verts = f["geometry/verts"][()]
    out = []
    for t in range(n_t):
        if pairs is not None:
            ji, jj = pairs[t, :, 0], pairs[t, :, 1]
        count, label = floe_labels(len(area), ji, jj, intact[t])
        cal = np.full(count, np.nan)
        if calipers:
            lon, lat = _node_lonlat(q[t], off, verts, radius)
            cal = mean_calipers(label, count, lon, lat, off, radius)
        out.append(Floes(float(times[t]), label, floe_areas(label, count, area), cal,
                         free_floes(label, count, flags)))
    return out


def _node_lonlat(q, off, verts, radius):
    """Vertex longitudes and latitudes [deg] of the elements at orientation ``q``."""
    from siku_core.geometry.element_geometry import polygons_lonlat

    ll = np.concatenate(polygons_lonlat(q, off, verts, radius))
    return ll[:, 0], ll[:, 1]


def output_distribution(path, per_decade: int = 5, min_tail: int = MIN_TAIL,
                        free_only: bool = True):
    """The floe size distribution dataset (:func:`distribution`) of an output file: of its free
    floes (``free_only``) or of all."""
    fl = output_floes(path)
    keep = [f.free if free_only else np.ones(len(f.area), bool) for f in fl]
    ds = distribution([f.area[k] for f, k in zip(fl, keep)], [f.time for f in fl],
                      per_decade=per_decade, min_tail=min_tail,
                      calipers_per_time=[f.caliper[k] for f, k in zip(fl, keep)])
    ds.attrs["floes"] = "free floes only" if free_only else "all floes, coast cells included"
    ds.attrs["source"] = f"siku fsd {path}"
    return ds


#: names that moved to :mod:`siku_io.analysis.gridded_fields`, the grid side of the floe sizes
__getattr__ = moved_names(__name__, {
    "GRID_FSD": "siku_io.analysis.gridded_fields",
    "grid_distribution": "siku_io.analysis.gridded_fields",
    "floe_cells": "siku_io.analysis.gridded_fields",
})
