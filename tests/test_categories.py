"""Thickness categories per element (siku_core.categories): kept from an ice cover with
categories, grown per category by thermodynamics (Stefan's law for each ``h_k``), the element
thickness their mean after every step, the volume budget, outputs with a ``category`` dimension
(HDF5, NetCDF, the xarray engine), restarts bit for bit, a scene without categories unchanged and
bad category data refused in one line.

The cover file is written here: concentration and thickness linear in longitude and latitude
(as in ``test_icecover.py``), split into three categories with fractions 0.2, 0.3, 0.5 of the
concentration at 0.5, 1 and 1.5 times the thickness."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from siku_core.run.cli import main
from siku_core.run.elements import build_elements_and_categories
from siku_core.errors import SceneError, StabilityError
from siku_core.interfaces import ElementSource, ElementSpec, Process
from siku_core.params import Param
from siku_core.scene.scene_file import load_scene, scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.state import MELTED
from siku_core.testing import scene_text
from siku_core.testing.scenes import square
from siku_core.testing.contact_cases import registry_with
from siku_core.testing.process_checks import ice_volume

K_I, L_F, T_F, RHO = 2.03, 3.34e5, -1.8, 910.0
SHARE = np.array([0.2, 0.3, 0.5])
SCALE = np.array([0.5, 1.0, 1.5])


def conc(lon, lat):  # 0.15 at the western edge (-160°) rising linearly to 1 at -150°
    return 0.15 + 0.085 * (np.asarray(lon) + 160.0)


def thick(lon, lat):  # 1 m at 72N, 0.5 m more per degree north, 0.02 m per degree east
    return 1.0 + 0.5 * (np.asarray(lat) - 72.0) + 0.02 * (np.asarray(lon) + 160.0)


def write_cover(path, share=SHARE, scale=SCALE):
    lon = np.arange(-162.0, -147.9, 0.5)
    lat = np.arange(70.0, 77.01, 0.25)
    LO, LA = np.meshgrid(lon, lat)
    c, h = np.clip(conc(LO, LA), 0.0, 1.0), thick(LO, LA)
    ds = xr.Dataset({
        "aicen": (("ncat", "lat", "lon"), np.asarray(share)[:, None, None] * c, {"units": "1"}),
        "hicen": (("ncat", "lat", "lon"), np.asarray(scale)[:, None, None] * h, {"units": "m"}),
    }, coords={"lat": ("lat", lat, {"units": "degrees_north"}),
               "lon": ("lon", lon, {"units": "degrees_east"})})
    ds.to_netcdf(path)


def cover_text(process="", dt=3600.0, steps=24, output="", cover_file="c.nc"):
    return f"""
[time]
start = 2001-01-01T00:00:00Z
duration = {dt * steps!r}
dt = {dt!r}
[elements]
thickness = 2.0
[elements.mesh]
lon = [-160.0, -150.0]
lat = [72.0, 75.0]
spacing = 30e3
land = "none"
cache = false
[elements.mesh.cover]
file = "{cover_file}"
concentration = "aicen"
thickness = "hicen"
category = "ncat"
threshold = 0.1
{process}
{output}
"""


def thermo(params: str, every: float | None = None) -> str:
    out = f'[[process]]\nname = "thermodynamics"\nparams = {{ {params} }}\n'
    return out + (f"every = {every!r}\n" if every is not None else "")


def cover_sim(tmp_path, process="", **kw) -> Simulation:
    if not (tmp_path / "c.nc").exists():
        write_cover(tmp_path / "c.nc")
    path = tmp_path / "cat.toml"
    path.write_text(cover_text(process, **kw))
    return Simulation(load_scene(path), out=False, progress=False)


def test_the_cover_categories_are_kept_and_give_the_element_thickness(tmp_path):
    write_cover(tmp_path / "c.nc")
    (tmp_path / "cat.toml").write_text(cover_text())
    st, cats = build_elements_and_categories(load_scene(tmp_path / "cat.toml"))
    assert cats is not None and cats.fraction.shape == (st.n, 3) and st.n > 20
    from siku_core.geometry.quat import latlon_of

    lat, lon = (np.degrees(x) for x in latlon_of(st.q))
    # the seeds are not the centroids: the fractions' ratios and the thickness ratios are exact
    np.testing.assert_allclose(cats.fraction / cats.fraction.sum(1)[:, None],
                               np.broadcast_to(SHARE, (st.n, 3)), rtol=1e-12)
    np.testing.assert_allclose(cats.thickness / cats.thickness[:, 1:2],
                               np.broadcast_to(SCALE, (st.n, 3)), rtol=1e-12)
    # sampled at seeds inside the cells: within the fields' change across a cell (30 km)
    assert np.allclose(cats.fraction.sum(1), conc(lon, lat), atol=0.085 * 1.5)
    assert np.allclose(cats.thickness[:, 1], thick(lon, lat), atol=0.5 * 0.8)
    assert np.array_equal(st.thickness, cats.mean())
    np.testing.assert_allclose(st.thickness, (SHARE * SCALE).sum() * cats.thickness[:, 1],
                               rtol=1e-12)
    # the mass counts the ice only: rho A sum a_k h_k, the concentration times a full cover's
    v = (cats.fraction * cats.thickness).sum(1)
    np.testing.assert_allclose(st.m, RHO * v * st.area, rtol=1e-15)
    np.testing.assert_allclose(st.m, RHO * cats.fraction.sum(1) * st.thickness * st.area,
                               rtol=4e-16 * 4)
    assert (cats.fraction.sum(1) < 0.99).any()  # the rule matters in this cover


@pytest.mark.parametrize("Ts,every", [(-30.0, None), (-15.0, 6 * 3600.0)])
def test_each_category_grows_by_stefans_law_and_the_thickness_stays_their_mean(
        tmp_path, Ts, every):
    sim = cover_sim(tmp_path, thermo(f"surface_temperature = {Ts}", every), steps=48)
    cats = sim.context.categories
    h0 = cats.thickness.copy()
    a0 = cats.fraction.copy()
    for _ in range(sim.n_steps):
        sim.run(steps=1)
        assert np.array_equal(sim.state.thickness, cats.mean())
    exact = np.sqrt(h0**2 + 2 * K_I * (T_F - Ts) * sim.time / (RHO * L_F))
    np.testing.assert_allclose(cats.thickness, exact, rtol=1e-6)
    assert np.array_equal(cats.fraction, a0)  # zero layers: no lateral growth
    # thin ice grows faster: the thinnest category gained the most
    gain = cats.thickness - h0
    assert (gain[:, 0] > gain[:, 1]).all() and (gain[:, 1] > gain[:, 2]).all()
    # and the mean grew by more than the mean thickness alone would have
    single = np.sqrt((a0 * h0).sum(1) ** 2 / a0.sum(1) ** 2
                     + 2 * K_I * (T_F - Ts) * sim.time / (RHO * L_F))
    assert (sim.state.thickness > single).all()
    np.testing.assert_allclose(sim.state.m, RHO * (a0 * cats.thickness).sum(1) * sim.state.area,
                               rtol=1e-15)


def test_thin_categories_melt_through_and_the_volume_budget_closes(tmp_path):
    # an ocean heat flux melts 1 m per 1.2 days (1.25 m in 36 h): the thin categories melt
    # through, the budget (sum of grown_volume) equals the change of the total volume to 1e-10
    F = RHO * L_F / (1.2 * 86400.0)
    sim = cover_sim(tmp_path, thermo(f"surface_temperature = -5.0, ocean_heat_flux = {F}, "
                                     "min_thickness = 0.3"), steps=36)
    cats = sim.context.categories
    a0 = cats.fraction.copy()
    v0 = ice_volume(sim)
    sim.run()
    assert (cats.thickness[:, 0] == 0.0).any()  # some categories melted through
    melted = sim.state.flags == MELTED
    assert melted.any() and not melted.all()
    assert np.array_equal(cats.fraction, a0)
    assert np.array_equal(sim.state.thickness, cats.mean())
    budget = sim.processes[0].budget(sim.context)
    assert ice_volume(sim) - v0 == pytest.approx(budget, rel=1e-10)


class _Thicken(Process):
    """Multiplies every thickness by 1.1 (a process that knows no categories)."""

    name = "thicken_all"
    conserves = ()

    def apply(self, ctx, dt):
        ctx.state.thickness[:] *= 1.1


class _Breaks(Process):
    """Sets a category fraction negative."""

    name = "breaks_categories"

    def apply(self, ctx, dt):
        ctx.categories.fraction[3, 1] = -0.1


def _with(tmp_path, cls):
    write_cover(tmp_path / "c.nc")
    text = cover_text(f'[[process]]\nname = "{cls.name}"\n', steps=2)
    scene = scene_from_text(text, "<categories>", path=tmp_path / "cat.toml")
    return Simulation(scene, out=False, progress=False, registry=registry_with("process", cls))


def test_a_thickness_change_alone_scales_every_category(tmp_path):
    sim = _with(tmp_path, _Thicken)
    cats = sim.context.categories
    h0, t0, a0 = cats.thickness.copy(), sim.state.thickness.copy(), cats.fraction.copy()
    sim.run(steps=1)
    np.testing.assert_allclose(cats.thickness, 1.1 * h0, rtol=4e-16 * 4)
    np.testing.assert_allclose(sim.state.thickness, 1.1 * t0, rtol=4e-16 * 8)
    assert np.array_equal(sim.state.thickness, cats.mean())
    assert np.array_equal(cats.fraction, a0)


def test_a_process_that_breaks_the_categories_stops_the_run_naming_the_element(tmp_path):
    sim = _with(tmp_path, _Breaks)
    with pytest.raises(StabilityError, match=r"breaks_categories.*element 3.*negative"):
        sim.run(steps=1)


class _TwoSquares(ElementSource):
    """Two squares: the first with the categories given as ``a``, ``h``, the second without."""

    name = "two_squares"
    params = {"a": Param([0.2, 0.5], "1", "fractions", type=list),
              "h": Param([0.4, 2.0], "m", "thicknesses", type=list)}

    def build(self, scene, seed, where):
        sq = [np.array(square((k * 0.2, 80.0), 2000.0)) for k in range(2)]
        return [ElementSpec(sq[0], thickness=9.0, label="first",
                            categories=(np.array(self.p["a"]), np.array(self.p["h"]))),
                ElementSpec(sq[1], thickness=1.25, label="second")]


def _two(a, h):
    txt = scene_text([], dt=60.0, duration=60.0, extra=(
        f'[[elements.source]]\nname = "two_squares"\nparams = {{ a = {a}, h = {h} }}\n'))
    return build_elements_and_categories(scene_from_text(txt, "<two>"),
                                         registry_with("element_source", _TwoSquares))


def test_a_source_gives_categories_and_an_element_without_has_one():
    st, cats = _two([0.2, 0.5], [0.4, 2.0])
    assert st.thickness[0] == (0.2 * 0.4 + 0.5 * 2.0) / 0.7  # the spec's 9 m is replaced
    assert np.array_equal(cats.fraction[1], [1.0, 0.0]) and st.thickness[1] == 1.25
    assert np.array_equal(cats.thickness[1], [1.25, 1.25])
    assert np.array_equal(st.thickness, cats.mean())
    with pytest.raises(SceneError, match=r"first: 2 category fractions and 3 category "):
        _two([0.2, 0.5], [0.4, 2.0, 3.0])
    with pytest.raises(SceneError, match=r"first: the category fractions sum to 0"):
        _two([0.0, 0.0], [0.4, 2.0])
    with pytest.raises(SceneError, match=r"first: its ice has no thickness"):
        _two([0.5, 0.0], [0.0, 2.0])


# ---------------------------------------------------------------------------- outputs, restart
@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("cat_out")
    write_cover(d / "c.nc")
    proc = thermo("surface_temperature = -30.0, ocean_heat_flux = 5.0")
    for writer, name in (("hdf5", "run.h5"), ("netcdf", "run.nc")):
        out = f'[output]\nfile = "{name}"\nwriter = "{writer}"\nevery = 21600.0\n'
        (d / f"{writer}.toml").write_text(cover_text(proc, output=out))
        assert main(["run", str(d / f"{writer}.toml"), "--out", str(d / name)]) == 0
    return d


def test_the_outputs_carry_the_categories_with_units(runs):
    ds = xr.open_dataset(runs / "run.h5", engine="siku")
    for k, units in (("category_fraction", "1"), ("category_thickness", "m")):
        assert ds[k].dims == ("time", "element", "category"), k
        assert ds[k].attrs["units"] == units
    a, h = ds["category_fraction"].values, ds["category_thickness"].values
    assert a.shape[2] == 3 and ds.sizes["time"] == 5
    # the thickness of every snapshot is the mean of its categories
    np.testing.assert_array_equal(ds["thickness"].values, (a * h).sum(2) / a.sum(2))
    assert (np.diff(h, axis=0) > 0).all()  # -30 °C: every category thickens
    nc = xr.open_dataset(runs / "run.nc")
    for k in ("category_fraction", "category_thickness", "thickness"):
        assert np.array_equal(nc[k].values, ds[k].values), k
        assert nc[k].attrs["units"] == ds[k].attrs["units"]
    pytest.importorskip("compliance_checker")
    from test_output_formats import cf_errors

    assert cf_errors(runs / "run.nc") == []


def test_siku_export_keeps_the_categories(runs):
    out = runs / "export.nc"
    assert main(["export", str(runs / "run.h5"), "--out", str(out)]) == 0
    nc = xr.open_dataset(out)
    h5 = xr.open_dataset(runs / "run.h5", engine="siku")
    assert nc["category_thickness"].dims == ("element", "obs", "category")
    assert np.array_equal(nc["category_thickness"].values,
                          h5["category_thickness"].values.transpose(1, 0, 2))
    pytest.importorskip("compliance_checker")
    from test_output_formats import cf_errors

    assert cf_errors(out) == []


def test_restart_with_categories_is_bit_for_bit(runs, tmp_path):
    part = tmp_path / "part.h5"
    (tmp_path / "c.nc").write_bytes((runs / "c.nc").read_bytes())
    proc = thermo("surface_temperature = -30.0, ocean_heat_flux = 5.0")
    out = '[output]\nfile = "part.h5"\nevery = 21600.0\n'
    (tmp_path / "half.toml").write_text(cover_text(proc, output=out, steps=12))
    (tmp_path / "whole.toml").write_text(cover_text(proc, output=out))
    assert main(["run", str(tmp_path / "half.toml"), "--out", str(part)]) == 0
    assert main(["run", str(tmp_path / "whole.toml"), "--out", str(part), "--restart",
                 str(part)]) == 0
    a = xr.open_dataset(runs / "run.h5", engine="siku")
    b = xr.open_dataset(part, engine="siku")
    assert a.sizes["time"] == b.sizes["time"] == 5
    for k in ("category_fraction", "category_thickness", "thickness", "mass", "grown_volume",
              "q"):
        assert np.array_equal(a[k].values, b[k].values), k


# ---------------------------------------------------------------------------- no categories
def test_a_scene_without_categories_allocates_nothing_for_them():
    txt = scene_text([(0.0, 80.0)], dt=3600.0, duration=7200.0, extra=thermo(
        "surface_temperature = -30.0"))
    sim = Simulation(scene_from_text(txt, "<plain>"), out=False, progress=False)
    assert sim.context.categories is None and sim.ice.before_process() is None
    sim.run()
    assert not any(k.startswith("category") for k in sim.element_fields())
    assert set(sim.history_arrays()["elements"]) == {"thickness", "flags", "grown_volume",
                                                     "growth_rate"}


# ---------------------------------------------------------------------------- bad input
def _refused(tmp_path, share, scale, *words):
    write_cover(tmp_path / "c.nc", share, scale)
    (tmp_path / "s.toml").write_text(cover_text(thermo("surface_temperature = -30.0")))
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", "s.toml", "--out",
                        "o.h5"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    # the one error line (after the mesh build's note)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip() and "mesh built" not in ln
             and "smallest free cell" not in ln]
    assert len(lines) == 1 and lines[0].startswith("siku: error: "), r.stderr
    for w in ("elements.mesh.cover", "ice cell", "c.nc", *words):
        assert w in lines[0], lines[0]
    assert not (tmp_path / "o.h5").exists()


def test_fractions_summing_above_one_are_refused_in_one_line(tmp_path):
    # 0.5 + 0.4 + 0.3 = 1.2 times the concentration: above 1 where it exceeds 0.83
    _refused(tmp_path, [0.5, 0.4, 0.3], SCALE, "sum to more than 1")


def test_a_negative_category_thickness_is_refused_in_one_line(tmp_path):
    _refused(tmp_path, SHARE, [-0.2, 1.0, 1.5], "thickness is negative")


# ---------------------------------------------------------------------------- ridging
class _RidgeTrio(ElementSource):
    """The ridging test's three squares (tests/test_processes.py: ridging_scene), each with two
    categories: a static wall (1.5 m, all ice), the carrier (2.2 m, 90 % ice) pressed on it and
    thin ice (0.54 m, 99.9 % ice: 4000 m² of open water) driven west onto the carrier at
    5 cm/s."""

    name = "ridge_trio"

    def build(self, scene, seed, where):
        size = 2000.0
        dlon = np.degrees(size / 6371000.0) / np.cos(np.radians(80.0))
        given = (("wall", -dlon, "static", None, [0.7, 0.3], [1.2, 2.2]),
                 ("carrier", 0.0, None, None, [0.5, 0.4], [1.0, 3.75]),
                 ("thin", dlon * 1.0005, "steady", (-0.05, 0.0), [0.6, 0.399], [0.3, 0.9]))
        return [ElementSpec(np.array(square((lon, 80.0), size)), flag=flag, velocity=vel,
                            label=label, categories=(np.array(a), np.array(h)))
                for label, lon, flag, vel, a, h in given]


def test_ridged_ice_piles_onto_the_carriers_thickest_category_and_conserves_volume():
    """The carrier's ridged volume ``dV`` goes into its thickest category ``m``: ``h_m``
    grows by ``dV / (a_m A)`` and its other categories stay as they were; a giver (the thin
    ice, 99.9 % covered) first closes its open water, then loses ice area: its fractions shrink
    in proportion, its category thicknesses stay; the volume ``sum A sum_k a_k h_k`` is
    conserved to round-off, the givers' lost volume is the ridged volume, their lost ice area
    is that volume over their ice's mean thickness, and every thickness is its categories'
    mean."""
    txt = scene_text([], dt=0.25, duration=100.0, extra=(
        '[[elements.source]]\nname = "ridge_trio"\n\n[contact]\nlaw = "ridging"\n'
        'joints = "none"\n\n[[process]]\nname = "ridging"\n'))
    sim = Simulation(scene_from_text(txt, "<ridging categories>"), out=False, progress=False,
                     registry=registry_with("element_source", _RidgeTrio))
    st, cats = sim.state, sim.context.categories
    a0, h0, t0 = cats.fraction.copy(), cats.thickness.copy(), st.thickness.copy()
    v0 = ice_volume(sim)
    sim.run()
    ridged = sim.context.fields["ridged_volume"]
    assert ridged[1] > 2e3 and ridged[0] == ridged[2] == 0.0  # m³: a real ridge, on the carrier
    assert ice_volume(sim) == pytest.approx(v0, rel=1e-12)
    assert np.array_equal(st.thickness, cats.mean())
    # the carrier: its fractions and thin category untouched, its thickest one carries the ridge
    assert np.array_equal(cats.fraction[1], a0[1]) and cats.thickness[1, 0] == h0[1, 0]
    grow = ridged[1] / (a0[1, 1] * st.area[1])
    assert cats.thickness[1, 1] == pytest.approx(h0[1, 1] + grow, rel=1e-12)
    # the givers: their thicknesses as they were, their fractions smaller in proportion
    assert np.array_equal(cats.thickness[[0, 2]], h0[[0, 2]])
    for e in (0, 2):
        r = cats.fraction[e].sum() / a0[e].sum()
        np.testing.assert_allclose(cats.fraction[e], r * a0[e], rtol=1e-12)
    assert cats.fraction[2].sum() < a0[2].sum()
    v0, v1 = (a0 * h0).sum(1), (cats.fraction * cats.thickness).sum(1)
    lost = st.area[[0, 2]] @ (v0[[0, 2]] - v1[[0, 2]])
    assert lost == pytest.approx(ridged[1], rel=1e-9)
    cut = st.area * (a0.sum(1) - cats.fraction.sum(1))  # m²: the ice area each lost
    for e in (0, 2):  # ... carried its volume at its own thickness
        assert cut[e] * t0[e] == pytest.approx(st.area[e] * (v0[e] - v1[e]), rel=1e-9)
    assert cut[2] > 1e3  # m²
    # its open water (0.1 % of it, 4000 m²) closed first: the overlap converted is larger by
    # that (Hibler's 1979 rule: the ice area shrinks only once no open water is left)
    ridging = sim.processes[0]
    closed = ridging.converted[:ridging.count][ridging.keys[:ridging.count] == 1 * 3 + 2]
    assert closed == pytest.approx(cut[2] + (1.0 - a0[2].sum()) * st.area[2], rel=1e-9)


# ---------------------------------------------------------------------------- gridding
COVER_A, COVER_H = [0.2, 0.3, 0.4], [0.5, 1.0, 2.0]


class _UniformPack(ElementSource):
    """Six by four squares of 20 km around 75 N, every one with the same categories."""

    name = "uniform_pack"

    def build(self, scene, seed, where):
        return [ElementSpec(np.array(square((-10.0 + 0.7 * i, 74.0 + 0.18 * j), 20e3)),
                            categories=(np.array(COVER_A), np.array(COVER_H)))
                for i in range(6) for j in range(4)]


def test_gridded_category_fractions_of_a_uniform_cover_equal_the_cover(tmp_path):
    """The category fraction of a cell is the mean of ``a_k`` over the ice in it (weighted by
    area) and the category thickness the mean ``h_k`` (weighted by the category's ice area):
    for a pack whose every element has the same categories both are the cover's own, in every
    cell with ice, partly covered or not (to round-off), and NaN in cells without; the same
    from the output file (``siku grid``) and from a running simulation."""
    from siku_io.analysis.gridded_fields import grid_output, grid_snapshot, snapshot_of
    from siku_forcing.gridded.regular_grid import Grid, GridCfg

    txt = scene_text([], dt=60.0, duration=120.0, extra=(
        '[[elements.source]]\nname = "uniform_pack"\n\n[[process]]\nname = "thermodynamics"\n'
        'params = { surface_temperature = -30.0 }\n'))
    sim = Simulation(scene_from_text(txt, "<uniform>"), out=tmp_path / "u.h5", progress=False,
                     registry=registry_with("element_source", _UniformPack))
    cfg = GridCfg(kind="lonlat", lon=(-12.0, -4.0), lat=(73.0, 76.0), resolution=0.5)
    live = grid_snapshot(Grid(cfg, sim.radius), snapshot_of(sim))
    sim.run()
    cats = sim.context.categories
    assert not np.array_equal(cats.thickness[0], COVER_H)  # the categories have grown
    ds = grid_output(tmp_path / "u.h5", cfg)
    frac, thick = ds["category_fraction"], ds["category_thickness"]
    assert frac.dims == thick.dims == ("time", "category", "lat", "lon")
    assert frac.attrs["units"] == "1" and thick.attrs["units"] == "m"
    ice = ds["concentration"].values > 0
    assert ice[-1].sum() > 10 and (~ice[-1]).sum() > 10
    for t, h in ((0, np.array(COVER_H)), (-1, cats.thickness[0])):
        for k in range(3):
            f, th = frac.values[t, k], thick.values[t, k]
            np.testing.assert_allclose(f[ice[t]], COVER_A[k], rtol=1e-12)
            np.testing.assert_allclose(th[ice[t]], h[k], rtol=1e-12)
            assert np.isnan(f[~ice[t]]).all() and np.isnan(th[~ice[t]]).all()
    np.testing.assert_array_equal(live["category_fraction"], frac.values[0])
    np.testing.assert_array_equal(live["category_thickness"], thick.values[0])
