"""Every count a user gives has a bound derived from the machine or the physics, refused in
one line naming the key and the allowed range: floating sub-steps, the spectral field's
Courant number, grid and spreading, gravity, and the processes' capacities."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from test_floating import block
from test_spectral import flume_scene

from siku_core.errors import SceneError
from siku_core.run.limits import physical_memory
from siku_core.scene.scene_file import load_scene, scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

SIZE = 2000.0
DLON = math.degrees(SIZE / 6371000.0) / math.cos(math.radians(80.0))


def one_line_exit_2(path):
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(path),
                        "--no-progress"], capture_output=True, text=True, cwd=path.parent,
                       timeout=300)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    return lines[0]


@pytest.mark.parametrize("params, key, allowed", [
    ("steps_per_period = 1000000000", "steps_per_period", "in [8, 4096]"),
    ("g = 0.0", "g", "in [0.01, 100]"),
])
def test_floating_counts_and_gravity_are_bounded(params, key, allowed):
    with pytest.raises(SceneError, match=f"key '{key}'.*{re_escape(allowed)}"):
        Simulation(scene_from_text(block(params, dt=0.1, duration=60.0), "<block>"),
                   out=False, progress=False)


def re_escape(s):
    import re
    return re.escape(s)


def test_floating_sub_steps_of_the_whole_run_are_bounded():
    """4096 sub-steps a period of a 10 m square (natural period ~3 s) in 1 s steps over 10⁶
    steps is 1.4e9 sub-steps: above the engine's 1e9 steps a run may take."""
    txt = block("steps_per_period = 4096", dt=1.0, duration=1e6)
    with pytest.raises(SceneError, match=r"steps_per_period = 4096 makes .* sub-steps in each "
                                         r"of the run's 1000000 steps.*allowed: "
                                         r"steps_per_period at most"):
        Simulation(scene_from_text(txt, "<block>"), out=False, progress=False)


@pytest.mark.parametrize("params, words", [
    ({"cfl": 0.001}, "key 'cfl' = 0.001: input should be greater than or equal to 0.1"),
    ({"spectrum": "jonswap", "n_directions": 8, "spreading": 1e300},
     "key 'spreading' = 1e+300: input should be less than or equal to 10000"),
    ({"g": 0.0}, "key 'g' = 0.0: input should be greater than or equal to 0.01"),
])
def test_spectral_field_bounds_are_one_line_naming_the_key(tmp_path, params, words):
    line = one_line_exit_2(flume_scene(tmp_path, params))
    assert words in line and "flume.toml" in line, line


def test_a_spectral_grid_past_the_memory_is_refused_naming_resolution(tmp_path):
    ram = physical_memory()
    # cells of 1 mm over the 2000 m × 100 m flume: 2e11 cells of one bin, 6 TB
    line = one_line_exit_2(flume_scene(tmp_path, {"resolution": 0.001}))
    assert "flume.toml [forcing[0].field] field 'spectral': resolution = 0.001 m" in line
    need = 32.0 * 2e6 * 1e5
    assert need > ram / 2
    most = float(line.split("allowed: resolution at least ")[1].split(" m")[0])
    assert most == pytest.approx(0.001 * math.sqrt(2 * need / ram), rel=1e-3)


def test_spectral_table_refusals_name_the_file_and_table(tmp_path):
    line = one_line_exit_2(flume_scene(tmp_path, {
        "spectrum": "table", "frequencies": [0.1, 0.12], "energy": [1.0, -0.5]}))
    assert "flume.toml [forcing[0].field] field 'spectral': 'energy' bin 1" in line, line


def test_ridging_capacity_past_the_memory_is_refused():
    els = [{"center": (k * DLON, 80.0), "thickness": 1.0} for k in range(2)]
    txt = scene_text(els, size=SIZE, dt=0.25, duration=1.0, extra=(
        '[contact]\nlaw = "ridging"\njoints = "none"\n\n[[process]]\nname = "ridging"\n'
        'params = { capacity = 1000000000000 }\n'))
    with pytest.raises(SceneError, match=r"\[process\[0\]\]: capacity = 1e\+12 needs .* GiB "
                                         r"of pairs remembered.*allowed: capacity at most"):
        Simulation(scene_from_text(txt, "<ridging>"), out=False, progress=False)


@pytest.mark.parametrize("params, key", [("weld_capacity = 1e12", "weld_capacity"),
                                         ("weld_pairs = 1000000000000", "weld_pairs")])
def test_refreeze_capacities_past_the_memory_are_refused(params, key):
    els = [{"center": (k * DLON, 80.0), "thickness": 1.0} for k in range(3)]
    txt = scene_text(els, size=SIZE, dt=0.25, duration=1.0, extra=(
        '[contact]\nlaw = "distributed_spring"\njoints = "pairs"\npairs = [[0, 1], [1, 2]]\n'
        f'\n[[process]]\nname = "refreeze"\nparams = {{ weld = true, {params} }}\n'))
    with pytest.raises(SceneError, match=f"{key} = 1e\\+12 needs .*allowed: {key} at most"):
        Simulation(scene_from_text(txt, "<row>"), out=False, progress=False)


def test_a_joint_slot_costs_at_most_the_bytes_the_bound_counts():
    from siku_core.run.limits import BYTES_PER_JOINT

    els = [{"center": (k * DLON, 80.0), "thickness": 1.0} for k in range(3)]
    txt = scene_text(els, size=SIZE, dt=0.25, duration=1.0, extra=(
        '[contact]\nlaw = "distributed_spring"\njoints = "pairs"\npairs = [[0, 1], [1, 2]]\n'
        '\n[[process]]\nname = "refreeze"\nparams = { weld = true, weld_capacity = 100 }\n'))
    cm = Simulation(scene_from_text(txt, "<row>"), out=False, progress=False).contacts
    slots = cm._slots
    n = len(slots["ji"])
    assert n >= 300
    assert sum(a.nbytes for a in slots.values()) / n <= BYTES_PER_JOINT
    assert np.all(slots["ji"][2:] == -1)


def test_a_scene_inside_the_bounds_still_builds(tmp_path):
    sim = Simulation(load_scene(flume_scene(tmp_path, {"cfl": 0.1})), out=False,
                     progress=False)
    assert sim.n_steps == 4


@pytest.mark.parametrize("key, value, allowed", [
    ("conductivity", 1e300, "[0.001, 10]"), ("latent_heat", 1.0, "[10000, 1e+06]"),
    ("ocean_heat_flux", 1e300, "[-1e+07, 1e+07]"), ("snow_conductivity", 1e300, "[0.001, 10]"),
    ("snow_thickness", 1e6, "[0, 10]"), ("new_ice_thickness", 1e6, "[0.001, 10]"),
    ("open_water_transfer", 1e300, "[0, 1000]")])
def test_absurd_thermodynamics_is_refused_at_load_naming_the_key(key, value, allowed):
    """Refused when the scene is read, in one line naming the key and its range, not by the
    engine's check on the thickness in the middle of the run."""
    txt = scene_text([(0.0, 80.0), (0.2, 80.0)], dt=60.0, duration=600.0, thickness=0.5,
                     extra=f'[[process]]\nname = "thermodynamics"\nparams = {{ {key} = '
                           f'{value!r} }}\n')
    with pytest.raises(SceneError, match=f"key '{key}'.*allowed: float in {re_escape(allowed)}"
                       ) as ei:
        Simulation(scene_from_text(txt, "<thermo>"), out=False, progress=False)
    assert len(str(ei.value).splitlines()) == 1


@pytest.mark.parametrize("spacing", [1e-300, 1e-200, 1e-9])
def test_a_tiny_mesh_spacing_with_the_default_land_mask_is_refused_in_one_line(spacing):
    """The land raster's size is counted without squaring the pixel (1e-300² is 0 in floating
    point): a tiny spacing is refused naming the key, never a ZeroDivisionError."""
    from siku_core.run.limits import check_limits

    txt = ('[time]\ndt = "60s"\nduration = "10min"\n\n[elements.mesh]\nlon = [-10.0, -9.0]\n'
           f'lat = [75.0, 75.5]\nspacing = {spacing!r}\n')
    with pytest.raises(SceneError, match=f"spacing {spacing:g} m over this box needs a land "
                                         "raster of .* pixels"):
        check_limits(scene_from_text(txt, "<mesh>"))


@pytest.mark.parametrize("spp, duration", [(4096, 1e6), (8, 1e9)])
def test_the_sub_step_advice_is_one_the_scene_can_follow(spp, duration):
    """The refusal of too many floating sub-steps advises a value the process takes: the
    largest steps_per_period whose sub-steps fit (following it runs, one more is refused), or,
    when even the least allowed (8) makes too many, the longest duration that fits. On main it
    advised "steps_per_period at most 2.667 (or a larger dt)": below the key's minimum of 8,
    and a larger dt makes as many sub-steps."""
    import re

    def refusal(spp, duration):
        try:
            Simulation(scene_from_text(block(f"steps_per_period = {spp}", dt=1.0,
                                             duration=duration), "<block>"),
                       out=False, progress=False)
        except SceneError as exc:
            return str(exc)
        return None

    msg = refusal(spp, duration)
    assert msg is not None and "larger dt" not in msg, msg
    if m := re.search(r"allowed: steps_per_period at most (\d+) for this scene", msg):
        most = int(m.group(1))
        assert 8 <= most < spp
        assert refusal(most, duration) is None
        assert "sub-steps" in refusal(most + 1, duration)
    else:
        m = re.search(r"even the least steps_per_period, 8, .*\[time\] duration at most "
                      r"(\d+) s", msg)
        assert m, msg
        assert refusal(spp, float(m.group(1))) is None
        assert "sub-steps" in refusal(spp, float(m.group(1)) + 1.0)
