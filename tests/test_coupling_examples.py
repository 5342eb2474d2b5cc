"""The coupling examples (``examples/coupling``) run and show what they claim: siku driven by the
CSDMS ``bmi-era5`` component, and waves and ice coupled both ways."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from siku_core.geometry.quat import centers
from siku_core.run.simulation import Simulation

EX = Path(__file__).resolve().parents[1] / "examples" / "coupling"
R = 6_371_000.0


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EX / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bmi_era5_drives_the_ice_as_the_same_wind_in_a_scene(tmp_path):
    """A uniform, steady 10 m wind served by ``BmiEra5`` from an ERA5-layout file moves the
    pack as the same wind given to ``air_drag`` in the scene, to round-off."""
    pytest.importorskip("bmi_era5")
    ew = _load("era5_winds")
    lon = np.arange(-152.0, -147.99, 0.25)
    lat = np.arange(76.0, 73.99, -0.25)
    u = np.full((4, len(lat), len(lon)), 8.0)
    v = np.full_like(u, -4.0)
    path = ew.write_era5(tmp_path / "era5.nc", lon, lat, np.arange(4), u, v)
    ice = ew.run(EX / "era5_ice.toml", path)
    assert ice.get_current_time() == 3 * 3600.0
    got = centers(ice.sim.state.q)
    ice.finalize()
    text = (EX / "era5_ice.toml").read_text()
    text = text.replace('source = "exchange"\nparams = {C = 0.0045}',
                        'source = "water_drag"\nparams = {C = 0.0045, spin_drag = false}')
    text = text.split("[coupling.grid]")[0] + (
        '[[forcing]]\nsource = "air_drag"\nfield = {type = "uniform", params = {u = 8.0, '
        'v = -4.0}}\n')
    (tmp_path / "ref.toml").write_text(text)
    ref = Simulation(tmp_path / "ref.toml", out=False, progress=False)
    start = centers(ref.state.q)
    ref.run()
    moved = R * np.linalg.norm(centers(ref.state.q) - start, axis=1)
    assert moved.min() > 500.0  # a few km of wind drift in 3 h
    assert R * np.abs(got - centers(ref.state.q)).max() <= 1e-9 * moved.max()


def test_two_way_waves_and_ice():
    """Ice -> waves: the wave model's attenuation over the flume is ``exp(-alpha S / W)``, ``S``
    the ice area of the elements and ``W`` the flume width (the ice cover siku reports holds all
    the ice). Waves -> ice: floes behind the ice edge surge less than floes at it when the waves
    are damped, and alike when they are not."""
    tw = _load("two_way_waves")
    ice, waves, rec = tw.run(duration=30.0)
    _, calm, rec0 = tw.run(duration=30.0, alpha=0.0)
    sim_area = float(np.sum(Simulation(EX / "waves_ice.toml", out=False).state.area))
    g = ice.grid
    W = R * (math.sin(math.radians(g.y_edges[-1])) - math.sin(math.radians(g.y_edges[0])))
    dx = waves.x[1] - waves.x[0]
    c_last = math.log(waves.a0 / waves.A[-1]) / waves.alpha  # sum c dx up to the last centre
    # the last columns hold no ice (the pack ends 100 m before the end of the flume)
    assert c_last == pytest.approx(sim_area / W, rel=1e-9)
    assert dx == pytest.approx(R * math.radians(0.00009), rel=1e-9)
    west, east = tw.surge(rec, 500, 600), tw.surge(rec, 900, 1000)
    west0, east0 = tw.surge(rec0, 500, 600), tw.surge(rec0, 900, 1000)
    assert west > 0.05  # the floes move with the waves
    # damped: A falls by exp(-alpha c 400 m) = 0.27 between the two bands
    assert west / east > 2.0
    assert 0.8 < west0 / east0 < 1.25


def test_coupling_guide_code_runs(monkeypatch):
    """The Python blocks of ``docs/howto/coupling.md`` run as written (from the repository)."""
    import re

    root = EX.parents[1]
    text = (root / "docs" / "howto" / "coupling.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks
    monkeypatch.chdir(root)
    for code in blocks:
        ns: dict = {}
        exec(compile(code, "coupling.md", "exec"), ns)
    # the block drove the pack with an 8 m/s wind for an hour: the ice cover is reported
    assert ns["conc"].sum() > 0
