"""Restart: N steps + save + restart + N steps equals 2N steps in one run, bit for bit."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from siku_core.run.cli import main
from siku_core.errors import SceneError
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_io.output.results import last_snapshot

N = 6
DT = 60.0
ELEMENTS = [
    {"center": (-150.0, 75.0), "velocity": (0.10, 0.05), "spin": 1e-5},
    {"center": (-147.5, 74.2), "velocity": (-0.05, 0.12)},
    {"center": (-152.0, 76.0), "spin": -2e-5},
]
FORCING = [
    {"source": "air_drag", "field": {"type": "cyclone", "params": {
        "lat": 74.5, "lon": -149.0, "vmax": 18.0, "rmax": 150e3, "move_east": 6.0}}},
    {"source": "water_drag"},
    {"source": "coriolis"},
]


def write_scene(path, integrator: str, steps: int, out: str = "run.h5") -> str:
    path.write_text(scene_text(ELEMENTS, forcing=FORCING, integrator=integrator, dt=DT,
                               duration=steps * DT, output={"file": out, "every": N * DT}),
                    encoding="utf-8")
    return str(path)


def final_state(path) -> dict[str, np.ndarray]:
    return last_snapshot(path)


def assert_bitwise_equal(a: dict, b: dict) -> None:
    assert a["step"] == b["step"]
    for k in ("q", "V", "w"):
        assert np.array_equal(a[k], b[k]), f"{k} differs: max |diff| {np.abs(a[k] - b[k]).max()}"


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_restart_continues_bit_for_bit_and_appends_to_the_same_file(tmp_path, integrator):
    scene = write_scene(tmp_path / "scene.toml", integrator, 2 * N)
    whole = Simulation(scene, out=tmp_path / "whole.h5", progress=False).run()
    assert whole.step_index == 2 * N

    part = tmp_path / "part.h5"
    first = Simulation(scene, out=part, progress=False).run(steps=N)
    assert first.step_index == N
    with h5py.File(part, "r") as f:
        steps_before = f["states/step"][:]
        q_before = f["states/q"][:]
        diag_before = f["diagnostics/step"][:]
    assert steps_before.tolist() == [0, N]

    second = Simulation(scene, out=part, restart=part, progress=False)
    assert second.restarted_from == N and second.step_index == N
    second.run()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(second.state, k), getattr(whole.state, k)), k
    assert_bitwise_equal(final_state(part), final_state(tmp_path / "whole.h5"))

    with h5py.File(part, "r") as f:  # appended: the first run's snapshots are still there
        assert f["states/step"][:].tolist() == [0, N, 2 * N]
        assert np.array_equal(f["states/q"][:2], q_before)
        diag = f["diagnostics/step"][:]
        assert np.array_equal(diag[: len(diag_before)], diag_before)
        assert (np.diff(diag) > 0).all() and diag[-1] == 2 * N
        with h5py.File(tmp_path / "whole.h5", "r") as g:
            assert np.array_equal(f["states/q"][:], g["states/q"][:])


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_cli_restart_continues_bit_for_bit(tmp_path, monkeypatch, integrator):
    """`siku run A` (N steps), then `siku run B --restart` (B runs to 2N) == `siku run B`."""
    monkeypatch.chdir(tmp_path)
    short = write_scene(tmp_path / "short.toml", integrator, N)
    full = write_scene(tmp_path / "full.toml", integrator, 2 * N)
    assert main(["run", full, "--out", "whole.h5", "--no-progress"]) == 0
    assert main(["run", short, "--no-progress"]) == 0  # writes run.h5 ([output] file)
    assert final_state("run.h5")["step"] == N
    assert main(["run", full, "--restart", "run.h5", "--no-progress"]) == 0
    assert_bitwise_equal(final_state("run.h5"), final_state("whole.h5"))
    with h5py.File("run.h5", "r") as f:
        assert f["states/step"][:].tolist() == [0, N, 2 * N]


def test_restart_into_another_file_leaves_the_first_untouched(tmp_path):
    scene = write_scene(tmp_path / "scene.toml", "siku2", 2 * N)
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    Simulation(scene, out=a, progress=False).run(steps=N)
    before = a.read_bytes()
    sim = Simulation(scene, out=b, restart=a, progress=False).run()
    assert a.read_bytes() == before
    with h5py.File(b, "r") as f:
        # the new file starts with the snapshot it continues from, then the new ones
        assert f["states/step"][:].tolist() == [N, 2 * N]
        assert np.array_equal(f["states/q"][-1], sim.state.q)


def test_running_one_simulation_twice_keeps_every_snapshot(tmp_path):
    """run(N); run(N) on one Simulation appends (the second run used to truncate the file)."""
    scene = write_scene(tmp_path / "scene.toml", "siku2", 2 * N)
    sim = Simulation(scene, out=tmp_path / "twice.h5", progress=False)
    sim.run(steps=N)
    sim.run(steps=N)
    whole = Simulation(scene, out=False, progress=False).run()
    assert np.array_equal(sim.state.q, whole.state.q)
    with h5py.File(tmp_path / "twice.h5", "r") as f:
        assert f["states/step"][:].tolist() == [0, N, 2 * N]


# ------------------------------------------------------------------ restarts that cannot go wrong
def scene_with(path, steps: int = 2 * N, dt: float = DT, integrator: str = "siku2",
               thickness: float | None = None, water_c: float | None = None,
               seed: int | None = None) -> str:
    forcing = [dict(f) for f in FORCING]
    if water_c is not None:
        forcing[1] = {"source": "water_drag", "params": {"C": water_c}}
    path.write_text(scene_text(ELEMENTS, forcing=forcing, integrator=integrator, dt=dt,
                               duration=steps * DT, thickness=thickness,
                               run=None if seed is None else {"seed": seed},
                               output={"file": "run.h5", "every": N * DT}), encoding="utf-8")
    return str(path)


@pytest.mark.parametrize("change, difference", [
    ({"dt": DT / 2}, "scene.time.dt: 60.0 -> 30.0"),
    ({"thickness": 2.0}, "scene.elements.thickness: 1.0 -> 2.0"),
    ({"integrator": "rk4"}, "scene.integrator.name: 'siku2' -> 'rk4'"),
    ({"water_c": 0.005}, "components.forcing2_water_drag.params.C: 0.0045 -> 0.005"),
    ({"seed": 3}, "scene.run.seed: 0 -> 3"),
])
def test_restart_with_a_different_scene_is_refused_with_the_differences(tmp_path, change,
                                                                        difference):
    part = tmp_path / "part.h5"
    Simulation(scene_with(tmp_path / "a.toml"), out=part, progress=False).run(steps=N)
    before = part.read_bytes()
    other = scene_with(tmp_path / "b.toml", **change)
    with pytest.raises(SceneError, match="restart refused: this scene differs from the run "
                                         "that wrote the file") as ei:
        Simulation(other, out=part, restart=part, progress=False)
    assert difference in str(ei.value) and "pass force=True to continue" in str(ei.value)
    assert part.read_bytes() == before
    with pytest.warns(UserWarning, match="restarting with a different scene"):
        sim = Simulation(other, out=part, restart=part, progress=False, force=True)
    assert sim.step_index == N


def test_restart_of_a_finished_run_says_how_to_extend_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = scene_with(tmp_path / "s.toml")
    assert main(["run", scene, "--no-progress"]) == 0
    assert main(["run", scene, "--no-progress", "--restart", "run.h5"]) == 2
    err = capsys.readouterr().err
    assert f"run.h5: the run is already complete (step {2 * N} of {2 * N}, t = 720 s); to run " \
           "longer, add --extend DURATION" in err


def test_extend_continues_a_finished_run_bit_for_bit_and_records_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = scene_with(tmp_path / "s.toml")
    longer = Simulation(scene_with(tmp_path / "long.toml", steps=3 * N), out="long.h5",
                        progress=False).run()
    assert main(["run", scene, "--no-progress"]) == 0
    assert main(["run", scene, "--no-progress", "--restart", "run.h5", "--extend",
                 f"{N * DT / 60:g}min"]) == 0
    assert_bitwise_equal(final_state("run.h5"), final_state("long.h5"))
    assert longer.step_index == 3 * N
    with h5py.File("run.h5", "r") as f, h5py.File("long.h5", "r") as g:
        assert f["states/step"][:].tolist() == [0, N, 2 * N, 3 * N]
        assert np.array_equal(f["states/q"][:], g["states/q"][:])
        assert f.attrs["n_steps"] == 3 * N
        assert f"# siku run --extend 360 s: continued from step {2 * N} of {2 * N} to step " \
               f"{3 * N}" in f["scene"][()].decode()


def test_extend_needs_a_restart_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", scene_with(tmp_path / "s.toml"), "--extend", "1h"]) == 2
    assert "--extend continues a finished run: give the file with --restart" in \
        capsys.readouterr().err


def test_restart_with_another_step_continues_the_model_time_to_the_scenes_end(tmp_path):
    """A restart with a changed dt goes on from the stored time: the time axis rises
    strictly, ends exactly at the scene's end, and the steps taken cover the time left."""
    part = tmp_path / "part.h5"
    Simulation(scene_with(tmp_path / "a.toml"), out=part, progress=False).run(steps=N)
    t_cut = last_snapshot(part)["time"]
    assert t_cut == N * DT
    other = scene_with(tmp_path / "b.toml", dt=DT / 2)
    with pytest.warns(UserWarning, match="restarting with a different scene"):
        sim = Simulation(other, out=part, restart=part, progress=False, force=True)
    assert sim.time == t_cut
    first = sim.step_index
    sim.run()
    end = 2 * N * DT  # the scene's duration [s]
    assert (sim.step_index - first) * sim.dt == end - t_cut
    assert sim.time == end
    with h5py.File(part, "r") as f:
        t = f["states/time"][:]
    assert np.all(np.diff(t) > 0), f"time axis goes back: {t.tolist()}"
    assert t[-1] == end
