"""Floe size distribution (siku_io.analysis.fsd): floes over intact joints, their areas and
mean calipers, and the maximum-likelihood power law of the areas (Clauset et al. 2009)."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from siku_io.analysis.fsd import (
    distribution,
    fit_alpha,
    floe_areas,
    floe_labels,
    mean_calipers,
    output_floes,
    power_law,
    tail_fit,
)


def sample_power_law(alpha, xmin, n, rng):
    """``n`` values of a continuous power law ``p(x) ~ x^-alpha`` above ``xmin`` (inverse
    transform: ``x = xmin (1 - u)^(-1/(alpha - 1))``)."""
    return xmin * (1.0 - rng.random(n)) ** (-1.0 / (alpha - 1.0))


@pytest.mark.parametrize("alpha", [1.6, 2.0, 2.5])
@pytest.mark.parametrize("n", [400, 4000])
def test_the_exponent_of_a_pure_power_law_is_recovered_within_two_standard_errors(alpha, n):
    rng = np.random.default_rng(0)
    fit = power_law(sample_power_law(alpha, 50.0, n, rng))
    assert abs(fit.alpha - alpha) < 2.0 * fit.alpha_se
    # the standard error is (alpha - 1)/sqrt(n_tail), Clauset et al. 2009 eq. 3.2
    assert fit.alpha_se == pytest.approx((fit.alpha - 1.0) / math.sqrt(fit.n_tail), rel=1e-12)
    assert fit.xmin >= 50.0


def test_two_standard_errors_cover_the_true_exponent_95_percent_of_the_time():
    # 200 samples of 300 floes: the share whose fit lies within 2 SE of the truth is
    # binomial about 0.954 (sd 0.015); the KS choice of the cut-off may lower it a little
    rng = np.random.default_rng(11)
    hits = [abs(f.alpha - 2.0) < 2.0 * f.alpha_se
            for f in (power_law(sample_power_law(2.0, 50.0, 300, rng)) for _ in range(200))]
    assert 0.90 <= np.mean(hits) <= 0.995


@pytest.mark.parametrize("alpha", [1.8, 2.2])
def test_the_cut_off_is_found_above_a_body_that_is_no_power_law(alpha):
    # 3000 floes of the power law above 200 m2 and 3000 uniform ones below it: the KS rule
    # must put the cut-off near 200 m2 and recover the exponent within two standard errors
    rng = np.random.default_rng(7 + int(alpha * 10))
    x = np.r_[sample_power_law(alpha, 200.0, 3000, rng), rng.uniform(10.0, 200.0, 3000)]
    fit = power_law(x)
    assert abs(fit.alpha - alpha) < 2.0 * fit.alpha_se
    assert 150.0 < fit.xmin < 300.0


def test_the_estimator_is_the_closed_form_of_clauset_et_al():
    x = np.array([1.0, 2.0, 4.0, 8.0])
    a, se, n = fit_alpha(x, 1.0)
    s = sum(math.log(v) for v in x)
    assert a == pytest.approx(1.0 + 4.0 / s, rel=1e-15) and n == 4
    assert se == pytest.approx((a - 1.0) / 2.0, rel=1e-15)


def grid_joints(nx, ny):
    """Joints of an ``nx × ny`` grid of cells (element ``iy * nx + ix``) between neighbours."""
    idx = np.arange(nx * ny).reshape(ny, nx)
    ji = np.r_[idx[:, :-1].ravel(), idx[:-1, :].ravel()]
    jj = np.r_[idx[:, 1:].ravel(), idx[1:, :].ravel()]
    return ji, jj


def test_a_grid_broken_along_known_lines_gives_its_rectangles():
    nx, ny = 7, 5
    ji, jj = grid_joints(nx, ny)
    col, row = np.arange(nx * ny) % nx, np.arange(nx * ny) // nx
    # break every joint crossing the lines between columns 2|3 and 5|6 and between rows 1|2
    side_x = np.searchsorted([3, 6], col, side="right")
    side_y = np.searchsorted([2], row, side="right")
    intact = (side_x[ji] == side_x[jj]) & (side_y[ji] == side_y[jj])
    count, label = floe_labels(nx * ny, ji, jj, intact)
    expected = side_y * 3 + side_x
    assert count == 6
    # the same partition: one label per expected piece and one piece per label
    pairs = set(zip(label.tolist(), expected.tolist()))
    assert len(pairs) == 6
    area = np.full(nx * ny, 4.0)  # 2 m cells
    a = floe_areas(label, count, area)
    widths, heights = np.array([3, 3, 1]), np.array([2, 3])
    want = sorted((4.0 * w * h) for h in heights for w in widths)
    assert sorted(a.tolist()) == want


def test_the_mean_caliper_of_a_square_is_four_sides_over_pi():
    # one 1 km square element at the equator: perimeter / pi = 4 km / pi
    R = 6_371_000.0
    h = math.degrees(500.0 / R)
    lon = np.array([-h, h, h, -h])
    lat = np.array([-h, -h, h, h])
    cal = mean_calipers(np.array([0]), 1, lon, lat, np.array([0, 4]), R)
    # the gnomonic projection stretches distances off the tangent point by (1 + O((L/R)^2))
    assert cal[0] == pytest.approx(4000.0 / math.pi, rel=1e-7)


def test_the_distribution_dataset_has_units_and_counts_every_floe():
    rng = np.random.default_rng(3)
    areas = [sample_power_law(2.0, 10.0, 500, rng), sample_power_law(1.8, 10.0, 800, rng)]
    ds = distribution(areas, [0.0, 60.0])
    assert ds["count"].values.sum(axis=1).tolist() == [500, 800]
    assert ds["pdf"].attrs["units"] == "m-2" and ds["area_bin"].attrs["units"] == "m2"
    width = ds["area_bin_upper"].values - ds["area_bin_lower"].values
    assert (ds["pdf"].values * width).sum(axis=1) == pytest.approx([1.0, 1.0], rel=1e-12)
    assert np.allclose(np.log10(ds["area_bin_upper"] / ds["area_bin_lower"]), 0.2)


@pytest.fixture(scope="module")
def broken_pack(tmp_path_factory):
    """A 6 x 4 pack of bonded 100 m elements whose joints across x = 2|3 columns and y = 1|2
    rows are broken before a two-step run writes its output."""
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    d = tmp_path_factory.mktemp("fsd")
    pack = square_pack(0.0, 0.0, 6, 4, size=100.0)
    txt = scene_text([], packs=[pack], dt=0.01, duration=0.02, thickness=1.0,
                     output={"file": str(d / "pack.h5"), "every": "0.01s"}, extra=(
                         '[contact]\nlaw = "distributed_spring"\n'
                         'params = { tensile_strain = 1.0 }\n'))
    (d / "pack.toml").write_text(txt)
    sim = Simulation(scene_from_text(txt, "<pack>", d / "pack.toml"), progress=False)
    cm = sim.contacts
    from siku_core.geometry.quat import latlon_of

    lat, lon = latlon_of(sim.state.q)
    lon0, lat0 = np.degrees(lon), np.degrees(lat)
    # column and row of each element from its centre
    ux, uy = np.unique(np.round(lon0, 9)), np.unique(np.round(lat0, 9))
    col = np.searchsorted(ux, np.round(lon0, 9))
    row = np.searchsorted(uy, np.round(lat0, 9))
    side = np.searchsorted([3], col, side="right") + 2 * np.searchsorted([2], row, side="right")
    cross = np.flatnonzero(side[cm.ji] != side[cm.jj])
    cm.break_joints(cross, 5, 0.0)
    sim.run()
    sim.close()
    return d / "pack.h5", side, sim.state.area.copy()


def test_floes_of_an_output_file_match_the_lines_it_was_broken_along(broken_pack):
    path, side, area = broken_pack
    fl = output_floes(path)
    assert len(fl) >= 2
    for f in fl:
        assert len(f.area) == 4
        assert len(set(zip(f.label.tolist(), side.tolist()))) == 4
        want = sorted(np.bincount(side, area).tolist())
        assert sorted(f.area.tolist()) == want  # the same sums of the same element areas
        # 3 x 2 cells of about 100 m: mean caliper = hull perimeter / pi
        assert np.allclose(sorted(f.caliper), 2 * (300 + 200) / math.pi, rtol=0.02)


def test_siku_fsd_writes_the_distribution_and_a_picture(broken_pack, tmp_path):
    import xarray as xr

    path = broken_pack[0]
    out, png = tmp_path / "pack.fsd.nc", tmp_path / "fsd.png"
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "fsd", str(path), "--out",
                        str(out), "--plot", str(png), "--min-tail", "2"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert (ds["n_floes"].values == 4).all()
        assert ds["count"].values.sum(axis=1).tolist() == [4] * ds.sizes["time"]
    assert png.stat().st_size > 1000
    again = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "fsd", str(path), "--out",
                            str(out)], capture_output=True, text=True)
    assert again.returncode == 2 and len(again.stderr.strip().splitlines()) == 1


def test_siku_fsd_of_a_missing_file_is_one_line_and_exit_2(tmp_path):
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "fsd",
                        str(tmp_path / "none.h5")], capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_a_tail_of_one_area_has_no_power_law():
    # areas equal to round-off (element areas summed in another order) are one value: no
    # exponent can be fitted to them
    x = np.r_[np.full(6, 100.0), 200.0 * (1 + 1e-13 * np.arange(6))]
    fit = power_law(x, min_tail=2)
    assert fit.xmin == pytest.approx(100.0) and fit.alpha < 10
    assert np.isnan(power_law(np.full(20, 50.0) * (1 + 1e-14 * np.arange(20))).alpha)


def break_line_grid():
    """A 2 x 2 lonlat grid whose cell edges are the lines the broken pack was broken along."""
    from siku_forcing.gridded.regular_grid import GridCfg

    dlat = math.degrees(100.0 / 6_371_000.0)
    dlon = dlat / math.cos(math.radians(2 * dlat))
    return GridCfg(kind="lonlat", lon=(0.0, 6 * dlon), lat=(0.0, 4 * dlat), dlon=3 * dlon,
                   dlat=2 * dlat, leads=False)


def test_floe_sizes_per_cell_of_a_grid_along_the_break_lines(broken_pack):
    # a 2 x 2 lonlat grid whose cell edges are the lines the pack was broken along: every cell
    # holds one whole floe (3 x 2 elements)
    from siku_io.analysis.gridded_fields import grid_distribution

    path, side, area = broken_pack
    cfg = break_line_grid()
    g = grid_distribution(path, cfg)
    floe = np.bincount(side, area)
    assert g["floe_number"].values == pytest.approx(np.ones((g.sizes["time"], 2, 2)), rel=1e-6)
    got = np.sort(g["floe_area_mean"].values[-1].ravel())
    assert got == pytest.approx(np.sort(floe), rel=1e-6)
    assert g["concentration"].values == pytest.approx(np.ones((g.sizes["time"], 2, 2)),
                                                      rel=1e-6)
    assert g["floe_area_mean"].attrs["units"] == "m2"


def test_siku_fsd_grid_without_an_output_grid_is_one_line_and_exit_2(broken_pack, tmp_path):
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "fsd", str(broken_pack[0]),
                        "--out", str(tmp_path / "a.nc"), "--grid", str(tmp_path / "g.nc")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "[output.grid]" in r.stderr
    assert not (tmp_path / "a.nc").exists()  # refused before the work
    assert len(r.stderr.strip().splitlines()) == 1


def test_siku_plot_draws_the_distribution_of_an_output_and_of_a_distribution_file(
        broken_pack, tmp_path):
    from siku_io.output.marks import is_picture

    path = broken_pack[0]
    cli = [sys.executable, "-m", "siku_core.run.cli"]
    r = subprocess.run([*cli, "plot", str(path), "--fsd", "--out-dir", str(tmp_path / "a")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    png = tmp_path / "a" / "pack_fsd.png"
    assert r.stdout.split() == [str(png)] and is_picture(png)
    nc = tmp_path / "pack.fsd.nc"
    assert subprocess.run([*cli, "fsd", str(path), "--out", str(nc), "--min-tail", "2"],
                          capture_output=True).returncode == 0
    for _ in range(2):  # the second replaces its own picture
        r = subprocess.run([*cli, "plot", str(nc), "--out-dir", str(tmp_path / "b")],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert is_picture(tmp_path / "b" / "pack_fsd.png")
    mine = tmp_path / "c" / "pack_fsd.png"
    mine.parent.mkdir()
    mine.write_bytes(b"a user's file")
    r = subprocess.run([*cli, "plot", str(nc), "--out-dir", str(mine.parent)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert mine.read_bytes() == b"a user's file"


def test_siku_grid_puts_the_floe_sizes_per_cell_among_its_fields(broken_pack):
    # the grid of the test above through siku grid: the same floe fields as siku fsd --grid
    from siku_io.analysis.gridded_fields import grid_distribution
    from siku_io.analysis.gridded_fields import grid_output

    path, side, area = broken_pack
    cfg = break_line_grid()
    g = grid_output(path, cfg)
    want = grid_distribution(path, cfg)
    for k in ("floe_number", "floe_area_mean", "floe_caliper_mean"):
        assert np.array_equal(g[k].values, want[k].values), k
    assert g["floe_area_mean"].attrs["units"] == "m2"
    assert sorted(g["floe_area_mean"].values[-1].ravel()) == pytest.approx(
        sorted(np.bincount(side, area)), rel=1e-6)
    only = grid_output(path, cfg.model_copy(update={"fields": ["floe_number"]}))
    assert "floe_number" in only and "floe_caliper_mean" not in only
    assert "floe_number" not in grid_output(path, cfg.model_copy(update={"fields": ["u"]}))


def test_siku_grid_without_the_runs_joints_grids_the_rest(broken_pack, monkeypatch, capsys):
    # a run whose scene cannot be built again: no floe fields by default (said on stderr), a
    # refusal when they are asked for by name
    from siku_core import DataError
    from siku_io.analysis import fsd
    from siku_io.analysis.gridded_fields import grid_output
    from siku_forcing.gridded.regular_grid import GridCfg

    def fails(path, calipers=True):
        raise DataError(f"{path}: its scene builds 3 joints but the file records 38")

    monkeypatch.setattr(fsd, "output_floes", fails)
    cfg = GridCfg(kind="lonlat", lon=(-0.01, 0.02), lat=(-0.01, 0.02), resolution=0.01,
                  leads=False)
    g = grid_output(broken_pack[0], cfg)
    assert "concentration" in g and "floe_number" not in g
    assert "no floe sizes on the grid" in capsys.readouterr().err
    with pytest.raises(DataError, match="38"):
        grid_output(broken_pack[0], cfg.model_copy(update={"fields": ["floe_area_mean"]}))


def test_floes_held_by_a_static_element_are_not_free_floes():
    from siku_io.analysis.fsd import free_floes

    # five elements in three floes; element 3 is a static coast cell, 4 steady
    label = np.array([0, 0, 1, 1, 2])
    assert free_floes(label, 3, [0, 0, 0, 1, 0]).tolist() == [True, False, True]
    assert free_floes(label, 3, [0, 0, 0, 0, 2]).tolist() == [True, True, False]


def test_the_distribution_of_an_output_is_of_its_free_floes(broken_pack):
    from siku_io.analysis.fsd import output_distribution

    path = broken_pack[0]
    fl = output_floes(path)
    assert all(f.free.all() for f in fl)  # the pack has no static element
    ds = output_distribution(path, min_tail=2)
    assert ds.attrs["floes"] == "free floes only"
    assert (ds["n_floes"].values == 4).all()


def test_no_power_law_is_fitted_to_a_tail_within_too_few_bins():
    from siku_io.analysis.fsd import MIN_BINS

    # 40 distinct areas within 10 % of each other: a maximum-likelihood exponent exists but the
    # tail lies in one or two of the 5-per-decade bins (each 58 % wide)
    x = 1e6 * (1 + 0.1 * np.linspace(0, 1, 40) ** 2)
    assert np.isfinite(power_law(x).alpha)
    ds = distribution([x], [0.0])
    assert np.count_nonzero(ds["count"].values[0]) < MIN_BINS
    assert np.isnan(ds["alpha"].values[0])
    # the same law over three decades is fitted
    rng = np.random.default_rng(5)
    ds = distribution([sample_power_law(2.0, 1e6, 400, rng)], [0.0])
    assert np.isfinite(ds["alpha"].values[0])


def test_a_power_law_is_refused_on_too_few_floes_or_bins_in_one_line():
    from siku_core import DataError

    rng = np.random.default_rng(7)
    x = sample_power_law(2.0, 1e4, 400, rng)
    fit = tail_fit(x)
    assert fit.alpha == power_law(x).alpha
    # nine floes: fewer than the tail needs
    with pytest.raises(DataError, match="9 floes: a power law needs at least 10") as exc:
        tail_fit(x[:9])
    assert "\n" not in str(exc.value)
    # forty floes within 10 % of each other: a tail in one or two bins
    with pytest.raises(DataError, match="area bin") as exc:
        tail_fit(1e6 * (1 + 0.1 * np.linspace(0, 1, 40) ** 2))
    assert "\n" not in str(exc.value)
