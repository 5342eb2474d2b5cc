"""The Python scene API (siku_core.scene.scene_api): the same checks and messages as a scene file,
TOML
both ways, and the default scene built in Python runs bit for bit as the shipped file."""
from __future__ import annotations

import os

import numpy as np
import pytest

from siku_core.run.cli import default_scene_path
from siku_core.errors import DataError, InputError, SceneError, SikuError
from siku_core.scene.scene_file import load_scene, scene_from_text
from siku_core.scene.scene_api import SceneBuilder, to_toml
from siku_core.run.simulation import Simulation

SHORT = "2min"


def default_scene_in_python() -> SceneBuilder:
    """The shipped default scene (siku_core/data/default_scene.toml), written in Python."""
    s = SceneBuilder("Beaufort-Chukchi lead formation", start="2001-04-06T00:00:00Z",
                     duration="24h", dt=1.5, base_dir=default_scene_path().parent,
                     name="default_scene")
    s.material("ice", youngs_modulus=0.5e9)
    s.elements(thickness=1.5)
    s.mesh(lon=[-168.0, -141.0], lat=[69.0, 75.0], spacing=8.5e3, coast_spacing=6e3,
           coast_distance=100e3, land="gshhg", seed=3,
           landfast=[[-156.9, 71.45], [-155.0, 71.3], [-152.0, 71.05], [-150.0, 70.85],
                     [-148.0, 70.6], [-146.0, 70.4], [-143.0, 70.3], [-141.5, 70.2],
                     [-141.5, 69.0], [-156.9, 69.0]])
    s.forcing("air_drag", field={"type": "gridded", "params": {
        "u_file": "uwnd.anticyclone.nc", "v_file": "vwnd.anticyclone.nc"}}, ramp="6h")
    s.forcing("water_drag")
    s.forcing("coriolis")
    s.contact("distributed_spring", params={"tensile_strain": 3e-4, "damping_ratio": 0.5,
                                            "joint_damping_ratio": 0.5})
    s.output(file="siku_default.h5", every="1h", plots=True)
    return s


def test_the_default_scene_built_in_python_runs_bit_for_bit_as_the_file():
    built = default_scene_in_python().set("time.duration", SHORT)
    assert built.validate().cfg == load_scene(default_scene_path(),
                                              {"time.duration": SHORT}).cfg
    a = built.run(out=False, progress=False)
    b = Simulation(load_scene(default_scene_path(), {"time.duration": SHORT}), out=False,
                   progress=False).run()
    assert a.step_index == b.step_index == a.n_steps > 60
    assert a.state.n == b.state.n > 5000
    for name in ("q", "V", "w"):
        x, y = getattr(a.state, name), getattr(b.state, name)
        assert x.tobytes() == y.tobytes(), name
    # the wind moved the ice (2 min into its 6 h spin-up it blows at 7.6e-5 of full strength:
    # speeds of about 1e-6 m/s), so the check compares motion
    assert np.abs(b.state.V).max() > 1e-7
    assert a.contacts.n_intact == b.contacts.n_intact


@pytest.mark.parametrize("change, expect", [
    (lambda s: s.time(step=1), "unknown key 'time.step'; allowed keys here: dt, duration, end, "
                               "start"),
    (lambda s: s.run_options(dt_safety=1.5), "allowed range: 0 < dt_safety <= 1"),
    (lambda s: s.integrator("verlet"), "unknown integrator 'verlet'; known: "),
    (lambda s: s.set("time.duration", "6"), "has no unit"),
])
def test_mistakes_give_the_messages_of_the_toml_path(change, expect, tmp_path):
    file = tmp_path / "my.toml"
    s = SceneBuilder("two floes", duration="10min", dt=60, label=str(file))
    s.polygon([[-150.0, 75.0], [-149.9, 75.0], [-149.9, 75.05], [-150.0, 75.05]])
    s.forcing("water_drag")
    change(s)
    file.write_text(s.to_toml(), encoding="utf-8")
    with pytest.raises(SikuError) as built:
        s.simulation(out=False)
    with pytest.raises(SikuError) as read:
        Simulation(file, out=False)
    assert str(built.value) == str(read.value) and type(built.value) is type(read.value)
    assert expect in str(built.value) and str(built.value).startswith(str(file))
    assert "\n" not in str(built.value)


def test_toml_both_ways_and_save_writes_only_a_valid_scene(tmp_path):
    s = SceneBuilder.load(default_scene_path())
    again = scene_from_text(s.to_toml(), "again", default_scene_path())
    assert again.cfg == load_scene(default_scene_path()).cfg
    assert SceneBuilder.from_toml(to_toml(s.data)).data == s.data
    one = SceneBuilder("one floe", duration="1h", dt="1min")
    one.polygon([[-150.0, 75.0], [-149.9, 75.0], [-149.9, 75.05], [-150.0, 75.05]])
    one.forcing("air_drag", field={"type": "uniform", "params": {"u": 10.0, "v": 0.0}})
    path = one.save(tmp_path / "one.toml")
    sim = Simulation(path, out=False, progress=False).run()
    assert sim.step_index == 60 and sim.state.V[0, 0] > 0.01  # blown east
    one.set("time.dt", -1)
    with pytest.raises(SceneError, match="dt"):
        one.save(tmp_path / "bad.toml")
    assert not (tmp_path / "bad.toml").exists()


# ------------------------------------------------------------ the user's files and misuse
def one_floe() -> SceneBuilder:
    s = SceneBuilder("one floe", duration="10min", dt="1min")
    s.polygon([[-150.0, 75.0], [-149.9, 75.0], [-149.9, 75.05], [-150.0, 75.05]])
    return s.forcing("water_drag")


def test_save_never_replaces_a_file_unless_told_and_never_through_a_link(tmp_path):
    """save() follows the rule of every file siku writes (outputs.check_target)."""
    mine = tmp_path / "mine.toml"
    mine.write_text('title = "a scene of the user"\n', encoding="utf-8")
    before = mine.read_bytes()
    with pytest.raises(DataError, match=r"mine\.toml: exists.*overwrite=True"):
        one_floe().save(mine)
    assert mine.read_bytes() == before
    link = tmp_path / "link.toml"
    link.symlink_to(mine)
    with pytest.raises(DataError, match=r"link\.toml: exists \(a symbolic link\)"):
        one_floe().save(link)
    assert mine.read_bytes() == before
    one_floe().save(link, overwrite=True)  # the link is replaced, never its target
    assert mine.read_bytes() == before and not link.is_symlink()
    assert SceneBuilder.load(link).data == one_floe().data
    dangling = tmp_path / "dangling.toml"
    dangling.symlink_to(tmp_path / "elsewhere.toml")
    with pytest.raises(DataError, match="symbolic link"):
        one_floe().save(dangling)
    assert not (tmp_path / "elsewhere.toml").exists()
    data = tmp_path / "data.bin"
    data.write_bytes(b"\xff\x00 not a scene")
    with pytest.raises(DataError, match="not a scene file siku wrote"):
        one_floe().save(data, overwrite=True)
    assert data.read_bytes() == b"\xff\x00 not a scene"
    one_floe().save(mine, overwrite=True)  # a scene file, replaced when told
    assert SceneBuilder.load(mine).data == one_floe().data


def test_save_refuses_a_fifo_without_opening_it(tmp_path):
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)  # opening it for writing would block for ever
    for overwrite in (False, True):
        with pytest.raises(DataError, match="not a regular file"):
            one_floe().save(fifo, overwrite=overwrite)


@pytest.mark.parametrize("misuse, expect", [
    (lambda s: s.set("forcing.3", {}), r"cannot set 'forcing\.3': the list holds 1 tables"),
    (lambda s: s.set(5, 1), r"cannot set 5: give a dotted key"),
    (lambda s: s.set("time..dt", 1), r"cannot set 'time\.\.dt'"),
    (lambda s: s.set("time", 5).time(dt=1), r"'time' holds int 5, not a table"),
    (lambda s: s.set("forcing", {}).forcing("coriolis"), r"'forcing' holds dict .* list of tab"),
    (lambda s: s.set("elements", []).pack(nx=1), r"'elements' holds list .* a table"),
    (lambda s: s.set("run", {1: 2}).to_toml(), r"1 \(int\) cannot be a key"),
])
def test_builder_misuse_raises_a_siku_error_naming_the_key(misuse, expect):
    with pytest.raises(SceneError, match=expect) as ei:
        misuse(one_floe())
    assert "\n" not in str(ei.value)


def test_load_of_a_folder_or_binary_file_is_a_scene_error(tmp_path):
    with pytest.raises(SceneError, match="cannot read a scene file"):
        SceneBuilder.load(tmp_path)
    (tmp_path / "x.h5").write_bytes(b"\x89HDF\r\n\x1a\n\xff\xfe")
    with pytest.raises(SceneError, match="not UTF-8 text"):
        SceneBuilder.load(tmp_path / "x.h5")


def test_run_past_the_scenes_end_is_refused_saying_how_many_steps_remain():
    sim = one_floe().simulation(out=False, progress=False)
    sim.run(steps=4)
    with pytest.raises(SceneError, match=r"run\(steps=7\) goes past the scene's end: 6 of 10 "
                                         r"steps remain"):
        sim.run(steps=7)
    assert sim.step_index == 4
    sim.run(steps=6)
    assert sim.step_index == sim.n_steps == 10


@pytest.mark.parametrize("misuse, expect", [
    (lambda s: s.time(dt=object()).to_toml(), r"key 'time\.dt': a value of type object cannot "
                                              r"be written"),
    (lambda s: s.process("thermodynamics", every=object()).validate(), r"key 'process\.every'"),
])
def test_a_value_a_scene_cannot_hold_is_refused_naming_its_key(misuse, expect):
    """On main: "cannot write object <object ...> in a scene", naming no key."""
    with pytest.raises(SceneError, match=expect) as ei:
        misuse(one_floe())
    assert "\n" not in str(ei.value)


@pytest.mark.parametrize("call, expect", [
    (lambda sb: Simulation(123, out=False), r"Simulation: scene = 123: give a Scene"),
    (lambda sb: sb.simulation(out=1.5), r"Simulation: out = 1\.5: give the path"),
    (lambda sb: sb.simulation(out=False, restart=7), r"Simulation: restart = 7: give the path"),
    (lambda sb: sb.simulation(out=False).run(steps=-1), r"Simulation\.run: steps = -1: give a "
                                                        r"whole number of steps, 0 or more"),
    (lambda sb: sb.simulation(out=False).run(steps=1.5), r"steps = 1\.5"),
    (lambda sb: sb.simulation(out=False).run(steps="3"), r"steps = '3'"),
    (lambda sb: scene_from_text(b"[time]", "x"), r"scene_from_text: text = b'\[time\]': give "
                                                 r"the scene's TOML text as a str"),
    (lambda sb: load_scene(None), r"load_scene: path = None: give the path of a scene file"),
])
def test_the_python_api_refuses_a_wrong_argument_with_an_input_error(call, expect):
    """A wrong argument of the Python API is one InputError naming the call, the argument and
    what to give (on main: TypeError or AttributeError from deep inside; run(steps=-1) ran
    nothing without a word)."""
    with pytest.raises(InputError, match=expect) as ei:
        call(one_floe())
    assert "\n" not in str(ei.value)
