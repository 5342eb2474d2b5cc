"""The winter scene (``examples/winter_beaufort``): at least two weeks of synthetic weather with
several storms, read through the gridded path, on the default scene's pack."""
from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent.parent / "examples" / "winter_beaufort"


def _storms():
    spec = importlib.util.spec_from_file_location("siku_winter_storms", HERE / "storms.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_winter_has_several_storms_over_two_weeks(tmp_path):
    import xarray as xr

    storms = _storms()
    u, v = storms.write(tmp_path)
    with xr.open_dataset(u) as du, xr.open_dataset(v) as dv:
        box = dict(lat=slice(77.5, 70.0), lon=slice(185.0, 220.0))  # the Beaufort Sea
        speed = np.hypot(du["uwnd"].sel(**box), dv["vwnd"].sel(**box)).max(("lat", "lon"))
        hours = (du["time"].values - du["time"].values[0]) / np.timedelta64(1, "h")
    s = speed.values
    assert hours[-1] >= 16 * 24
    # storms: peaks of the strongest wind over the sea above 10 m/s, a day or more apart,
    # with calmer weather (below 80 % of the peak) between them
    peaks = [k for k in range(1, len(s) - 1) if s[k] >= s[k - 1] and s[k] > s[k + 1]
             and s[k] > 10.0]
    apart = [peaks[0]] + [p for a, p in zip(peaks, peaks[1:])
                          if hours[p] - hours[a] >= 24 and s[a:p].min() < 0.8 * min(s[a], s[p])]
    assert len(apart) >= 4, (peaks, s.round(1))
    # files of the same names are never replaced
    try:
        storms.write(tmp_path)
    except FileExistsError:
        pass
    else:
        raise AssertionError("the wind files were replaced")


@pytest.mark.parametrize("name", ["winter_beaufort.toml", "winter_heterogeneous.toml"])
def test_the_winter_scene_reads_its_wind_and_runs(tmp_path, name):
    """Both winters (as shipped, and with spread joint strengths, damage and refreezing) run
    two weeks or more with the 6 h ramp at a stable step; the heterogeneous one is the same
    pack with the three ingredients added."""
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    storms = _storms()
    shutil.copy(HERE / name, tmp_path)
    storms.write(tmp_path)
    scene = load_scene(tmp_path / name)
    assert scene.cfg.time.total >= 14 * 86400.0
    assert scene.cfg.forcing[0].ramp == 6 * 3600.0
    sim = Simulation(scene, out=False, progress=False)
    assert sim.dt <= scene.cfg.run.dt_safety * sim.critical_dt
    if name == "winter_heterogeneous.toml":
        assert [p.name for p in scene.cfg.process] == ["joint_strength", "refreeze"]
        assert scene.cfg.contact.params["damage_onset"] == 0.5
    sim.run(steps=3)
    assert np.isfinite(sim.state.V).all()


def test_the_coastal_box_has_boxes_of_many_elements_and_runs(tmp_path):
    """The coastal box (``coastal_box.toml``): elements of about 6 km (the square root of the
    median area; 5 km spacing), so a 10 km box holds about three and a 20 km one about eleven;
    a stable step; its first steps run."""
    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    shutil.copy(HERE / "coastal_box.toml", tmp_path)
    _storms().write(tmp_path)
    scene = load_scene(tmp_path / "coastal_box.toml")
    sim = Simulation(scene, out=False, progress=False)
    free = sim.state.flags == 0
    size = float(np.sqrt(np.median(sim.state.area[free])))  # m
    assert 5.0e3 < size < 6.5e3 and free.sum() > 500
    assert (10e3 / size) ** 2 >= 2.5 and (20e3 / size) ** 2 >= 10.0
    assert sim.dt <= scene.cfg.run.dt_safety * sim.critical_dt
    sim.run(steps=3)
    assert np.isfinite(sim.state.V).all()
