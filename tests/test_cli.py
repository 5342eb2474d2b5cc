"""Command line: one-line errors with exit status 2, the default scene, plugins, --out."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core import __version__
from siku_core.run.cli import default_scene_path, main
from siku_core.testing import scene_text

GOOD = scene_text([(-150.0, 75.0), (-149.0, 75.0)], dt=60.0, duration=300.0,
                  forcing=[{"source": "water_drag"}, {"source": "coriolis"}])


def write(tmp_path: Path, text: str, name: str = "scene.toml") -> str:
    (tmp_path / name).write_text(text, encoding="utf-8")
    return name


def one_line_error(capsys, argv: list[str]) -> str:
    """Run ``main(argv)``; it must return 2 and print exactly one ``siku: error:`` line."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("siku: error: "), err
    assert "Traceback" not in err
    return lines[0]


BAD_INPUT = [
    ("missing-scene", None, [], "nowhere.toml: scene file not found"),
    ("malformed-toml", GOOD + "\n[run\n", [], "scene.toml: TOML syntax error"),
    ("unknown-key", GOOD.replace("dt = 60.0", "dt = 60.0\nstep = 1"), [],
     "unknown key 'time.step'; allowed keys here: dt, duration, end, start"),
    ("out-of-range", GOOD + "\n[run]\ndt_safety = 1.5\n", [],
     "allowed range: 0 < dt_safety <= 1"),
    ("unknown-plugin", GOOD.replace('"siku2"', '"verlet"'), [],
     "unknown integrator 'verlet'; known: "),
    ("unstable-dt", GOOD.replace("dt = 60.0", "dt = 900.0").replace("duration = 300.0",
                                                                     "duration = 1800.0"),
     [], "set by 'water_drag'"),
    ("missing-restart", GOOD, ["--restart", "gone.h5"], "gone.h5: restart file not found"),
    ("bad-argument", GOOD, ["--frobnicate"], "unrecognized arguments: --frobnicate"),
]


@pytest.mark.parametrize("case, text, extra, expect", BAD_INPUT, ids=[c[0] for c in BAD_INPUT])
def test_bad_input_exits_2_with_one_line_on_stderr(tmp_path, monkeypatch, capsys, case, text,
                                                   extra, expect):
    monkeypatch.chdir(tmp_path)
    name = "nowhere.toml" if text is None else write(tmp_path, text)
    line = one_line_error(capsys, ["run", name, "--no-progress", *extra])
    assert expect in line
    assert not (tmp_path / "siku_out.h5").exists() or case == "missing-restart"


def test_several_problems_are_joined_on_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    bad = GOOD.replace("dt = 60.0", "dt = -1.0\nstep = 1")
    line = one_line_error(capsys, ["run", write(tmp_path, bad)])
    assert "time.dt" in line and "time.step" in line and " | " in line


def test_unknown_command_exits_2_with_one_line(capsys):
    line = one_line_error(capsys, ["simulate"])
    assert "invalid choice: 'simulate'" in line


def test_version_and_help_return_0(capsys):
    assert main(["--version"]) == 0
    assert __version__ in capsys.readouterr().out


def test_run_without_a_scene_runs_the_shipped_default_scene(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--no-progress", "--no-plots", "--set", "time.duration=30min"]) == 0
    err = capsys.readouterr().err
    assert "Beaufort-Chukchi lead formation" in err and "siku_default.h5" in err
    out = tmp_path / "siku_default.h5"
    with h5py.File(out, "r") as f:
        scene = f["scene"][()].decode()
        assert scene.startswith(default_scene_path().read_text(encoding="utf-8").rstrip("\n"))
        assert scene.endswith("# time.duration = 30min\n")
        assert f["plugins"].attrs["siku"] == __version__
        n = f.attrs["n_elements"]
        assert f["states/q"].shape[1:] == (n, 4)
        dt = f.attrs["dt_requested"]
        steps = int(np.ceil(1800 / dt))  # the fitted step ends the run exactly at 30 min
        assert f["states/step"][0] == 0 and f["states/step"][-1] == steps
        assert f["states/time"][-1] == pytest.approx(1800.0, abs=1e-9)
        assert f["states/step"].shape[0] == f["states/q"].shape[0]  # every snapshot complete
    assert not list(tmp_path.glob("*.png"))  # --no-plots


def test_set_needs_key_equals_value(capsys):
    assert main(["run", "--set", "time.duration"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["siku: error: --set 'time.duration': write KEY=VALUE, e.g. "
                   "--set time.duration=6h"]


def test_set_values_are_validated_like_the_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--set", "time.dt=-1s"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "time.dt" in err[0] and "default_scene.toml" in err[0]


def test_out_overrides_the_scene_output_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, GOOD + '\n[output]\nfile = "from_scene.h5"\n')
    assert main(["run", name, "--out", "results/custom.h5", "--no-progress"]) == 0
    assert (tmp_path / "results" / "custom.h5").is_file()
    assert not (tmp_path / "from_scene.h5").exists()
    assert "results/custom.h5" in capsys.readouterr().err
    with h5py.File(tmp_path / "results" / "custom.h5", "r") as f:
        assert f["states/step"][-1] == 5


def test_warning_for_an_allowed_unstable_dt_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    text = GOOD.replace("dt = 60.0", "dt = 900.0").replace("duration = 300.0", "duration = 1800.0")
    name = write(tmp_path, text + "\n[run]\nallow_unstable_dt = true\n")
    assert main(["run", name, "--no-progress"]) == 0
    warn = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]
    assert len(warn) == 1 and warn[0].startswith("siku: warning: ")
    assert "set by 'water_drag'" in warn[0]


def test_plugins_lists_components_with_units_and_allowed_values(capsys):
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    for name in ("siku2", "rk4", "air_drag", "water_drag", "coriolis", "cyclone", "uniform",
                 "hdf5"):
        assert f"  {name}  (siku {__version__})" in out
    assert "rho = 1026.0  [kg/m^3]  water density rho_w; allowed: float >= 0 kg/m^3" in out
    assert "vmax = 15.0  [m/s]" in out


def test_plugins_lists_an_installed_third_party_plugin(siku_fake_install, capsys):
    root = Path(__file__).resolve().parents[1] / "examples" / "siku_example_plugin"
    siku_fake_install("siku-example-plugin", "0.1", {"example": "siku_example_plugin.plugin"},
                      paths=[root], top_level=["siku_example_plugin"])
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    assert "  sea_surface_tilt  (siku-example-plugin 0.1)" in out
    assert "  euler  (siku-example-plugin 0.1)" in out
    assert "slope_east = 0.0  [m/m]  eastward sea-surface slope" in out


def test_warm_builds_a_scene_and_takes_two_steps_without_output(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(elements=[(-150.0, 75.0)], duration=3600, dt=60),
                     encoding="utf-8")
    assert main(["warm", str(scene)]) == 0
    err = capsys.readouterr().err
    assert "siku warm:" in err and "1 element " in err and "kernels" in err
    assert list(tmp_path.iterdir()) == [scene]  # nothing written
