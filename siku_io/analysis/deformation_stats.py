"""Deformation statistics: the total deformation rate coarse-grained over space and time, its
scaling exponents and its distribution (Marsan et al. 2004; the caveats of Hutchings et al. 2024
for floe-resolving models apply).

For a time scale ``T`` (a whole number of snapshot intervals) each free element's velocity is
its displacement between two snapshots ``T`` apart divided by ``T`` (east/north, in a plane
about the pack's centre: azimuthal equidistant, ``x`` east and ``y`` north at the centre). For a
length scale ``L`` the plane is cut into ``L × L`` boxes; in every box holding at least three
elements whose convex hull covers at least ``min_cover`` of the box, the velocity gradient is the
line integral of the velocity round the hull over its area (as ``siku grid`` computes strain
rates, after the RGPS cells of Kwok et al. 2008), and the total deformation rate is

    eps = sqrt(div² + shear²),  div = ux + vy,  shear = sqrt((ux - vy)² + (uy + vx)²)   [1/s].

The spatial scaling ``<eps>(L) ∝ L^-beta`` at fixed ``T`` and the temporal scaling
``<eps>(T) ∝ T^-alpha`` at fixed ``L`` are least-squares slopes of ``log <eps>`` against
``log L`` (``log T``) over the scales given (the fit range), each with its standard error and a
95 % interval (1.96 standard errors). The rate distribution is that of the boxes at the smallest
``L`` and ``T``: log-spaced histogram, and the share above ``0.01 /day``. The higher moments
``<eps^q>`` (``q = 1, 2, 3``) per scale give the structure-function exponents ``beta(q)``
(multifractality: ``beta(q)`` convex in ``q``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DAY = 86400.0
#: the rate above which a box counts as deforming in the distribution's share [1/s]
ACTIVE_RATE = 0.01 / DAY


def box_rates(x: np.ndarray, y: np.ndarray, u: np.ndarray, v: np.ndarray, L: float,
              min_cover: float = 0.5) -> np.ndarray:
    """Total deformation rate [1/s] of every ``L × L`` box (from the minimum of ``x``, ``y``)
    holding at least three points whose hull covers ``min_cover`` of the box."""
    from siku_io.analysis.gridded_fields import strain_rates

    ix = np.floor((x - x.min()) / L).astype(np.int64)
    iy = np.floor((y - y.min()) / L).astype(np.int64)
    key = iy * (int(ix.max()) + 1) + ix
    order = np.argsort(key, kind="stable")
    ks = key[order]
    cuts = np.flatnonzero(np.diff(ks)) + 1
    out = []
    for grp in np.split(order, cuts):
        if len(grp) < 3:
            continue
        ux, uy, vx, vy, area = strain_rates(x[grp], y[grp], u[grp], v[grp])
        if not area >= min_cover * L * L or not np.isfinite(ux):
            continue
        div = ux + vy
        shear = np.hypot(ux - vy, uy + vx)
        out.append(np.hypot(div, shear))
    return np.asarray(out)


def _fit(scales: np.ndarray, means: np.ndarray) -> tuple[float, float]:
    """Slope ``-b`` of ``log means`` against ``log scales``: ``(b, standard error)``."""
    ok = np.isfinite(means) & (means > 0)
    s, m = np.log(scales[ok]), np.log(means[ok])
    if len(s) < 2:
        return np.nan, np.nan
    A = np.column_stack([s, np.ones_like(s)])
    coef, res, *_ = np.linalg.lstsq(A, m, rcond=None)
    n = len(s)
    if n > 2:
        resid = m - A @ coef
        se = float(np.sqrt(resid @ resid / (n - 2) / np.sum((s - s.mean()) ** 2)))
    else:
        se = 0.0
    return float(-coef[0]), se


@dataclass
class DeformationStats:
    """``moments[q][iT, iL]``: ``<eps^q>`` [(1/s)^q] over the boxes of length scale
    ``scales[iL]`` [m] and time scale ``times[iT]`` [s]; ``counts[iT, iL]`` boxes;
    ``beta[iT]``, ``beta_se[iT]`` the spatial exponent of ``<eps>`` at each time scale;
    ``alpha[iL]``, ``alpha_se[iL]`` the temporal one at each length scale; ``rates`` the box rates
    at the smallest scales (the distribution)."""

    scales: np.ndarray
    times: np.ndarray
    moments: dict[int, np.ndarray]
    counts: np.ndarray
    beta: np.ndarray
    beta_se: np.ndarray
    alpha: np.ndarray
    alpha_se: np.ndarray
    rates: np.ndarray
    beta_q: dict[int, float] = field(default_factory=dict)

    @property
    def active_share(self) -> float:
        """Share of the smallest-scale boxes deforming faster than 0.01 /day."""
        return float(np.mean(self.rates > ACTIVE_RATE)) if len(self.rates) else np.nan

    def histogram(self, bins: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """Probability density of the smallest-scale rates on log-spaced bins [1/day]:
        ``(density, edges)``."""
        r = self.rates[self.rates > 0] * DAY
        if not len(r):
            return np.zeros(0), np.zeros(0)
        edges = np.logspace(np.log10(r.min()), np.log10(r.max()), bins + 1)
        dens, _ = np.histogram(r, edges, density=True)
        return dens, edges

    def table(self) -> str:
        """A plain-text report: ``<eps>`` per scale [1/day], the exponents with 95 % intervals
        and their fit ranges, and the distribution's share above 0.01 /day."""
        lines = ["T [h] \\ L [km] " + " ".join(f"{L / 1e3:9.1f}" for L in self.scales)]
        for i, T in enumerate(self.times):
            lines.append(f"{T / 3600:14.1f} " + " ".join(
                f"{m * DAY:9.4f}" for m in self.moments[1][i]))
        def fit_range(values, means, unit, scale):
            # the scales the fit used: those with boxes (a scale below the element size has
            # none, and its mean is NaN)
            ok = np.asarray(values)[np.isfinite(means) & (np.asarray(means) > 0)]
            if len(ok) < 2:
                return "too few scales with boxes"
            return f"{ok[0] / scale:g}-{ok[-1] / scale:g} {unit}"

        m1 = self.moments[1]
        for i, T in enumerate(self.times):
            lines.append(f"beta (T = {T / 3600:g} h, fit over "
                         f"{fit_range(self.scales, m1[i], 'km', 1e3)}) = {self.beta[i]:.3f} "
                         f"± {1.96 * self.beta_se[i]:.3f}")
        for j, L in enumerate(self.scales):
            lines.append(f"alpha (L = {L / 1e3:g} km, fit over "
                         f"{fit_range(self.times, m1[:, j], 'h', 3600)}) = {self.alpha[j]:.3f} "
                         f"± {1.96 * self.alpha_se[j]:.3f}")
        for q, b in self.beta_q.items():
            lines.append(f"beta(q = {q}) = {b:.3f}")
        lines.append(f"share of {self.scales[0] / 1e3:g} km, {self.times[0] / 3600:g} h rates "
                     f"above 0.01 /day: {self.active_share:.1%} of {len(self.rates)} boxes")
        return "\n".join(lines)


def statistics(positions: list[tuple[np.ndarray, np.ndarray]], dt: float, scales,
               steps=(1,), min_cover: float = 0.5) -> DeformationStats:
    """Deformation statistics of element centres ``positions[k] = (x, y)`` [m] in a plane at
    snapshots ``dt`` [s] apart, the same elements in the same order at every snapshot; over the
    length ``scales`` [m] and time scales ``steps`` (whole numbers of snapshot intervals). Every
    pair of snapshots ``n`` apart that fits gives one sample per box."""
    scales = np.asarray(sorted(scales), float)
    steps = sorted(int(s) for s in steps)
    nT, nL = len(steps), len(scales)
    sums = {q: np.zeros((nT, nL)) for q in (1, 2, 3)}
    counts = np.zeros((nT, nL), np.int64)
    smallest: list[np.ndarray] = []
    for iT, n in enumerate(steps):
        T = n * dt
        for k in range(0, len(positions) - n, n):
            (x0, y0), (x1, y1) = positions[k], positions[k + n]
            u, v = (x1 - x0) / T, (y1 - y0) / T
            xm, ym = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            for iL, L in enumerate(scales):
                r = box_rates(xm, ym, u, v, L, min_cover)
                for q in sums:
                    sums[q][iT, iL] += np.sum(r**q)
                counts[iT, iL] += len(r)
                if iT == 0 and iL == 0:
                    smallest.append(r)
    with np.errstate(invalid="ignore", divide="ignore"):
        moments = {q: s / counts for q, s in sums.items()}
    times = np.array(steps, float) * dt
    beta = np.empty(nT)
    beta_se = np.empty(nT)
    for i in range(nT):
        beta[i], beta_se[i] = _fit(scales, moments[1][i])
    alpha = np.empty(nL)
    alpha_se = np.empty(nL)
    for j in range(nL):
        alpha[j], alpha_se[j] = _fit(times, moments[1][:, j]) if nT > 1 else (np.nan, np.nan)
    beta_q = {q: _fit(scales, moments[q][0])[0] for q in moments}
    return DeformationStats(scales, times, moments, counts, beta, beta_se, alpha, alpha_se,
                            np.concatenate(smallest) if smallest else np.zeros(0), beta_q)


def plane_positions(lon: np.ndarray, lat: np.ndarray, lon0: float, lat0: float,
                    radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Azimuthal equidistant ``x`` (east at the centre), ``y`` (north) [m] of points [deg] about
    ``(lon0, lat0)``: distances from the centre are true, and within a few hundred km of it
    the plane's lengths are within a fraction of a per cent of the sphere's."""
    la, lo = np.radians(lat), np.radians(lon)
    la0, lo0 = np.radians(lat0), np.radians(lon0)
    c = np.clip(np.sin(la0) * np.sin(la) + np.cos(la0) * np.cos(la) * np.cos(lo - lo0), -1, 1)
    ang = np.arccos(c)
    k = np.where(ang > 0, ang / np.maximum(np.sin(ang), 1e-300), 1.0)
    x = k * np.cos(la) * np.sin(lo - lo0)
    y = k * (np.cos(la0) * np.sin(la) - np.sin(la0) * np.cos(la) * np.cos(lo - lo0))
    return radius * x, radius * y


def output_statistics(path, scales, steps=(1,), min_cover: float = 0.5) -> DeformationStats:
    """:func:`statistics` of the free elements of a run's output file (every snapshot)."""
    from siku_io.output.xr import open_output

    ds = open_output(path)
    R = float(ds.attrs["radius"])
    from siku_io.analysis.gridded_fields import snapshot_seconds

    seconds = np.asarray(snapshot_seconds(ds), float)
    dts = np.diff(seconds)
    if len(dts) == 0 or not np.allclose(dts, dts[0], rtol=1e-9):
        from siku_core import DataError

        raise DataError(f"{path}: deformation statistics need at least two snapshots at a "
                        "constant interval")
    lon = ds["lon"].values
    lat = ds["lat"].values
    free = ds["flags"].values == 0 if "flags" in ds else np.ones(lon.shape[-1], bool)
    lon0 = float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(lon[0][free]))))))
    lat0 = float(np.mean(lat[0][free]))
    pos = [plane_positions(lon[k][free], lat[k][free], lon0, lat0, R) for k in range(len(lon))]
    return statistics(pos, float(dts[0]), scales, steps, min_cover)
