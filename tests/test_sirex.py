"""Deformation metrics with the RGPS method (siku_io.analysis.sirex) on fields with known
answers.

* **A straight crack.** Points on a square lattice of spacing ``h``; those above the line
  ``y = (j + 1/2) h`` slide east at ``U``. The lattice's cells tile it in squares, and the boxes
  (from the lattice's corner, ``L`` a multiple of ``h``) hold whole squares, so a box's cells
  cover ``L²`` exactly; the velocity is linear on every cell, so the line integral round a box
  is that of the box: ``uy = U L / L²`` in a box the crack crosses, 0 elsewhere. Of the
  ``(D / L)²`` boxes ``D / L`` hold the crack: ``<eps^q> = (L / D) (U / L)^q`` and
  ``beta(q) = q - 1`` exactly (to rounding), the quadratic fit ``a = 0``, ``b = 1``,
  ``c = -1``; the rate does not change with the interval (``alpha = 0``); the cells across the
  crack are one linear feature as long as the lattice, along ``x``.
* **A log-normal multiplicative cascade** on ``2^n × 2^n`` cells: each level splits a cell in
  four and multiplies each quarter by ``W = exp(s g - s²/2)`` (``g`` standard normal, ``<W> =
  1``, ``<W^q> = exp(s² q (q - 1) / 2)``). The mean of a box of ``2^k`` cells a side is the
  product of the ``n - k`` weights above it times ``Z_k``, the mean of a ``k``-level cascade,
  independent of them: ``E[eps_L^q] = <W^q>^(n-k) E[Z_k^q]``. For integer ``q``, ``E[Z_k^q]``
  follows from ``Z_k = (1/4) sum_i W_i Z_(k-1)^(i)`` by the multinomial expansion
  (``E[Z_k] = 1``; ``E[Z_k²] = (<W²> E[Z_(k-1)²] + 3) / 4``; ``E[Z_k³] = (4 <W³> E[Z_(k-1)³]
  + 36 <W²> E[Z_(k-1)²] + 24) / 64``), so the exponent the fit should find over the scales
  used is the least-squares slope of ``log E[eps_L^q]`` (``log2 <W^q> = s² q (q - 1) /
  (2 ln 2)`` for an infinitely deep cascade). The estimate pools the moments of ``M``
  independent cascades; its sampling error is the jackknife's over them (leave one cascade
  out), and the estimate falls within three of its standard errors (99.7 % for a normal
  estimator; the bias of the log of a pooled mean is second order in that error).
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_io.analysis.sirex import (
    DAY, QS, cells, coarse_grain, fit_slope, sirex, structure_fit, total_rate)

H = 5e3  # lattice spacing [m]
NS = 128  # squares a side: the boxes of 10-320 km tile the 640 km lattice


def crack_positions(U: float, T: float, n_snap: int = 2):
    i, j = np.meshgrid(np.arange(NS + 1), np.arange(NS + 1))
    x, y = (i * H).ravel().astype(float), (j * H).ravel().astype(float)
    above = y > (NS // 2 + 0.5) * H
    return [(x + np.where(above, U * T * k, 0.0), y) for k in range(n_snap)]


def test_a_straight_crack_gives_q_minus_one():
    T = 3600.0
    U = 0.01 * H / T  # a cell across the crack: 0.24 /day
    scales = [H * 2**k for k in range(1, 7)]
    s = sirex(crack_positions(U, T, 3), T, scales, steps=(1, 2), lkf_rate=0.05 / DAY)
    # two intervals of one snapshot, one of two: every box of each
    assert s.dropped == [] and np.all(s.counts == [[2], [1]] * (NS * H / s.scales) ** 2)
    for q in QS:
        want = (s.scales / (NS * H)) * (U / s.scales) ** q
        np.testing.assert_allclose(s.moments[q][0], want, rtol=1e-9)
        assert s.beta_q[q] == pytest.approx(q - 1, abs=1e-9)
    assert (s.a, s.b, s.c) == pytest.approx((0.0, 1.0, -1.0), abs=1e-9)
    assert s.alpha == pytest.approx(0.0, abs=1e-9)
    # one feature per interval, across the lattice and along x
    assert s.lkf_counts == [1, 1]
    assert np.all(s.lkf_lengths >= (NS - 2) * H) and np.all(s.lkf_lengths <= NS * H)
    assert np.all(np.minimum(s.lkf_angles, 180 - s.lkf_angles) < 1.0)
    # the cells across the crack are its only deforming ones: 2 NS of 2 NS² at each interval
    assert s.tail == pytest.approx(1.0 / NS, rel=1e-12)


def test_no_scale_below_the_cells_is_reported():
    T = 3600.0
    pos = crack_positions(0.01 * H / T, T)
    s = sirex(pos, T, [H / 2, H, 2 * H, 4 * H], min_scale=1.5 * H)
    assert s.dropped == [H / 2, H] and list(s.scales) == [2 * H, 4 * H]
    assert "not reported" in s.table()


def test_the_cells_drop_slivers_and_long_sides():
    x = np.array([0.0, 1.0, 0.5, 0.5, 10.0])
    y = np.array([0.0, 0.0, 0.8, -0.02, 0.0])
    tri = cells(x, y, max_side=2.0, min_angle=20.0)
    for t in tri:  # kept: well shaped, short and counter-clockwise
        px, py = x[t], y[t]
        assert np.max(np.hypot(px - np.roll(px, 1), py - np.roll(py, 1))) <= 2.0
        assert (px[1] - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (py[1] - py[0]) > 0
    # Delaunay also has 1-2-4 and 1-3-4: sides of 9 and more, and angles of 5 deg and less
    # at point 4; 0-2-3 and 1-2-3 have their smallest angles near 32 deg
    from scipy.spatial import Delaunay

    assert len(Delaunay(np.column_stack([x, y])).simplices) == 4
    assert sorted(sorted(t) for t in tri.tolist()) == [[0, 2, 3], [1, 2, 3]]
    assert len(cells(x, y, max_side=100.0, min_angle=20.0)) == 2  # the angles alone
    assert len(cells(x, y, max_side=100.0, min_angle=35.0)) == 0


def cascade(n: int, s2: float, rng) -> np.ndarray:
    f = np.ones((1, 1))
    for _ in range(n):
        f = np.kron(f, np.ones((2, 2)))
        f = f * np.exp(np.sqrt(s2) * rng.standard_normal(f.shape) - 0.5 * s2)
    return f


def expected_beta(q: int, n: int, ks, s2: float) -> float:
    Wq = {1: 1.0, 2: np.exp(s2), 3: np.exp(3 * s2)}
    m = {1: [1.0], 2: [1.0], 3: [1.0]}
    for _ in range(max(ks)):
        m2, m3 = m[2][-1], m[3][-1]
        m[1].append(1.0)
        m[2].append((Wq[2] * m2 + 3) / 4)
        m[3].append((4 * Wq[3] * m3 + 36 * Wq[2] * m2 + 24) / 64)
    logE = [(n - k) * np.log(Wq[q]) + np.log(m[q][k]) for k in ks]
    return -np.polyfit(np.log(2.0**np.asarray(ks)), logE, 1)[0]


def test_a_multiplicative_cascade_is_recovered_within_its_sampling_error():
    n, s2, M = 8, 0.2, 16
    ks = [3, 4, 5, 6, 7]
    rng = np.random.default_rng(58)
    N = 2**n
    cx, cy = (a.ravel() + 0.5 for a in np.meshgrid(np.arange(N), np.arange(N)))
    area = np.ones(N * N)
    per = []  # per cascade: sums of eps^q and box counts per scale
    for _ in range(M):
        e = cascade(n, s2, rng).ravel()
        grad = np.zeros((N * N, 4))
        grad[:, 1] = e  # a pure shear of rate e: total rate e
        assert np.allclose(total_rate(grad), e)
        sums = {}
        for q in (1, 2, 3):
            sums[q] = [np.sum(coarse_grain(cx, cy, area, grad, 2.0**k, 1.0, (0.0, 0.0)) ** q)
                       for k in ks]
        per.append(sums)
    counts = np.array([(N / 2**k) ** 2 for k in ks])
    L = 2.0 ** np.asarray(ks)

    def beta(sel, q):
        tot = np.sum([per[m][q] for m in sel], axis=0)
        return fit_slope(L, tot / (counts * len(sel)))[0]

    got = {}
    for q in (1, 2, 3):
        b = beta(range(M), q)
        jk = np.array([beta([m for m in range(M) if m != i], q) for i in range(M)])
        se = np.sqrt((M - 1) / M * np.sum((jk - jk.mean()) ** 2))
        want = expected_beta(q, n, ks, s2)
        if q == 1:
            assert b == pytest.approx(0.0, abs=3 * se + 1e-12) and want == 0.0
        else:
            assert abs(b - want) <= 3 * se, (q, b, want, se)
            assert se < 0.1 * want  # the test resolves the exponent
        got[q] = b
    # convex, and far from the crack's q - 1
    a, b_, c = structure_fit([1, 2, 3], [got[1], got[2], got[3]])
    assert a > 0 and got[3] < 2.0 - 0.5


def test_the_picture_of_beta_q_and_the_distribution(tmp_path):
    from siku_io.analysis.sirex import plot_sirex

    T = 3600.0
    s = sirex(crack_positions(0.01 * H / T, T), T, [H * 2**k for k in range(1, 6)])
    plot_sirex(s, tmp_path / "sirex.png")
    assert (tmp_path / "sirex.png").stat().st_size > 10_000


def test_the_fastest_five_percent_carry_all_of_a_crack_and_five_percent_of_a_uniform_strain():
    T = 3600.0
    s = sirex(crack_positions(0.01 * H / T, T), T, [H * 2**k for k in range(1, 6)])
    # the cells across the crack (1/NS = 0.8 % of them) deform, the others not at all
    assert s.top_share(0.05) == pytest.approx(1.0, abs=1e-12)
    i, j = np.meshgrid(np.arange(NS + 1), np.arange(NS + 1))
    x, y = (i * H).ravel().astype(float), (j * H).ravel().astype(float)
    g = 1e-7  # uniform shear [1/s]: every cell deforms at the same rate
    u = sirex([(x, y), (x + g * T * y, y)], T, [H * 2**k for k in range(1, 6)])
    n = len(u.rates)
    assert u.top_share(0.05) == pytest.approx(round(0.05 * n) / n, rel=1e-9)
    assert "carry" in u.table()


def test_a_window_keeps_the_snapshots_between_its_ends():
    from siku_core import DataError
    from siku_io.analysis.sirex import window_snapshots

    seconds = 1e6 + 10800.0 * np.arange(17)  # 48 h every 3 h
    assert list(window_snapshots(seconds, (86400.0, 172800.0))) == list(range(8, 17))
    assert list(window_snapshots(seconds, (0.0, 86400.0))) == list(range(9))
    with pytest.raises(DataError, match="1 snapshot"):
        window_snapshots(seconds, (172800.0, 200000.0), "run.h5")


@pytest.mark.parametrize("window", ["12h", "12h,soon", "1,2h"])
def test_a_window_that_is_not_two_durations_is_refused_in_one_line(window, capsys):
    from siku_core.run.cli import main

    assert main(["deformation", "run.h5", "--sirex", "--window", window]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and "--window" in err[0] and "Traceback" not in err[0]


def test_an_output_whose_flags_are_per_snapshot_is_read(monkeypatch):
    """A run with processes writes ``flags`` per snapshot: the metrics take the elements free
    in every snapshot, and give the crack's ``q - 1`` as from the positions."""
    import xarray as xr

    import siku_io.output.xr as sxr
    from siku_io.analysis.sirex import output_sirex

    R = 6371e3
    T = 3600.0
    pos = crack_positions(0.01 * H / T, T, 3)
    lon = np.degrees(np.array([x for x, _ in pos]) / R)  # a small patch at the equator
    lat = np.degrees(np.array([y for _, y in pos]) / R)
    n = lon.shape[1]
    flags = np.zeros((3, n), np.int8)
    ds = xr.Dataset({"lon": (("time", "element"), lon), "lat": (("time", "element"), lat),
                     "flags": (("time", "element"), flags),
                     "area": (("element",), np.full(n, H * H))},
                    coords={"time": [0.0, T, 2 * T]}, attrs={"radius": R})
    monkeypatch.setattr(sxr, "open_output", lambda path: ds)
    s = output_sirex("run.h5", [H * 2**k for k in range(1, 6)], (1,))
    assert len(s.rates) == 2 * 2 * NS * NS  # every element free: two intervals of 2 NS² cells
    for q in (1.0, 2.0, 3.0):
        assert s.beta_q[q] == pytest.approx(q - 1, abs=0.02)
