"""What a new user meets first: the summary at the end of a run and ``siku info`` for any output,
``siku plugins NAME|KIND``, durations without a unit refused naming the key."""
from __future__ import annotations

import re

import numpy as np

import pytest

from siku_core.run.cli import main

from test_cli import GOOD, one_line_error, write

PAIR = """title = "a pair pulled apart"
[time]
duration = "10min"
dt = 1
[elements]
thickness = 1.0
[[elements.polygon]]
vertices = [[-150.1737, 74.955], [-149.8263, 74.955], [-149.8263, 75.045], [-150.1737, 75.045]]
velocity = [-1.0, 0.0]
[[elements.polygon]]
vertices = [[-149.8263, 74.955], [-149.4789, 74.955], [-149.4789, 75.045], [-149.8263, 75.045]]
velocity = [1.0, 0.0]
[contact]
law = "distributed_spring"
joints = "auto"
params = { tensile_strain = 1e-5 }
[output]
file = "pair.h5"
every = "5min"
"""


def _rows(text: str) -> dict[str, str]:
    return {m.group(1): m.group(2) for m in re.finditer(r"^  (\w[\w ]*?)\s{2,}(.*)$", text, re.M)}


def test_a_run_ends_with_a_summary_and_siku_info_prints_it_from_the_file(tmp_path, monkeypatch,
                                                                         capsys):
    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, GOOD + '\n[output]\nfile = "two.h5"\nevery = 60\n')
    assert main(["run", name, "--no-progress"]) == 0
    err = capsys.readouterr().err
    summary = err[err.index("summary:"):]
    rows = _rows(summary)
    assert rows["elements"] == "2: 2 free"
    assert rows["steps"] == "5 of 60 s: 5 min of model time (complete)"
    assert rows["output"] == "two.h5" and re.fullmatch(r"[\d.]+ s \([\d.]+ steps/s\)",
                                                        rows["wall time"])
    assert main(["info", "two.h5"]) == 0
    info = _rows(capsys.readouterr().out)
    # the same numbers from the file alone (no wall time is recorded in the file)
    assert {k: v for k, v in info.items() if k != "output"} == \
        {k: v for k, v in rows.items() if k not in ("output", "wall time")}
    assert info["output"] == "two.h5"


def test_the_summary_counts_joints_broken_by_mode_and_the_lead_fraction(tmp_path, monkeypatch,
                                                                      capsys):
    """Two frozen floes pulled apart at 2 m/s: their joint breaks, and the summary says by
    what; siku info reads the same from the file."""
    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, PAIR)
    assert main(["run", name, "--no-progress"]) == 0
    rows = _rows(capsys.readouterr().err.split("summary:")[1])
    m = re.fullmatch(r"(\d+) frozen: (\d+) intact, (\d+) broken(?: \((.*)\))?", rows["joints"])
    assert m, rows["joints"]
    assert tuple(map(int, m.groups()[:3])) == (1, 0, 1)
    assert re.fullmatch(r"[a-z]+ 1", m.group(4))
    assert re.fullmatch(r"lead fraction [\d.e+-]+ % \(open water in leads [\d.e+-]+ km²\)",
                        rows["leads"])
    assert main(["info", "pair.h5"]) == 0
    assert _rows(capsys.readouterr().out)["joints"] == rows["joints"]


def test_siku_info_refuses_what_is_not_an_output_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert "nowhere.h5: no such file" in one_line_error(capsys, ["info", "nowhere.h5"])
    (tmp_path / "scene.toml").write_text(GOOD)
    assert "scene.toml: not an HDF5 file" in one_line_error(capsys, ["info", "scene.toml"])


def test_plugins_filters_by_name_or_kind(capsys):
    assert main(["plugins", "air_drag"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "forcing sources:" and out[1].startswith("  air_drag  (siku ")
    assert all(ln.startswith("      ") for ln in out[2:]) and len(out) >= 4
    for kind in ("contact_law", "contact laws"):
        assert main(["plugins", kind]) == 0
        text = capsys.readouterr().out
        names = re.findall(r"^  (\w+)  \(", text, re.M)
        assert text.splitlines()[0] == "contact laws:"
        assert {"collision", "distributed_spring", "mohr_coulomb", "bonded_particle"} <= set(names)
        assert "air_drag" not in names
    assert main(["plugins"]) == 0
    everything = capsys.readouterr().out
    assert len(everything.splitlines()) > 3 * len(text.splitlines())


def test_plugins_with_an_unknown_name_lists_kinds_and_names(capsys):
    line = one_line_error(capsys, ["plugins", "air_dreg"])
    assert "no component or kind of that name" in line and "air_drag" in line \
        and "contact_law" in line


@pytest.mark.parametrize("key", ["time.duration", "time.dt", "output.every"])
def test_a_duration_without_a_unit_on_the_command_line_is_refused_naming_the_key(
        tmp_path, monkeypatch, capsys, key):
    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, GOOD)
    line = one_line_error(capsys, ["run", name, "--set", f"{key}=6"])
    assert f"--set {key}=6: a duration on the command line needs its unit" in line
    assert "scene.toml" in line and not list(tmp_path.glob("*.h5"))


def test_a_duration_as_text_without_a_unit_is_refused_naming_the_key(tmp_path, monkeypatch,
                                                                    capsys):
    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, GOOD.replace("duration = 300.0", 'duration = "300"'))
    line = one_line_error(capsys, ["run", name])
    assert "scene.toml" in line and "time.duration" in line and "has no unit" in line
    # numbers are seconds in a scene file, and other keys take numbers on the command line
    name = write(tmp_path, GOOD, "ok.toml")
    assert main(["run", name, "--no-progress", "--set", "time.duration=120s",
                 "--set", "run.dt_safety=0.4", "--out", "ok.h5"]) == 0
    assert "2 steps" in capsys.readouterr().err


@pytest.mark.parametrize("argv, made", [
    (["grid", "run.h5", "--lon", "0", "1", "--lat", "0", "1", "--resolution", "0.5"],
     "run.grid.nc"),
    (["export", "run.h5"], "run.nc"),
])
def test_commands_refuse_an_existing_output_before_doing_the_work(tmp_path, monkeypatch, capsys,
                                                                  argv, made):
    """siku grid and siku export check their output first: no minutes of gridding for a
    refusal (the work itself would fail here: run.h5 is not an output)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run.h5").write_text("not an output")
    (tmp_path / made).write_text("kept")
    line = one_line_error(capsys, argv)
    assert f"{made}: exists; choose another --out, or pass --overwrite" in line
    assert (tmp_path / made).read_text() == "kept"


def test_outlines_at_takes_an_index_or_a_time_and_names_the_range(tmp_path, monkeypatch):
    import xarray as xr

    from siku_io.output.xr import outlines_at

    monkeypatch.chdir(tmp_path)
    name = write(tmp_path, GOOD + '\n[output]\nfile = "two.h5"\nevery = 60\n')
    assert main(["run", name, "--no-progress"]) == 0
    with xr.open_dataset("two.h5", engine="siku") as ds:
        last = outlines_at(ds, -1)
        assert len(last) == 2 and last[0].shape[1] == 2
        for t in (ds.time[-1], ds.time.values[-1]):
            got = outlines_at(ds, t)
            assert all(np.array_equal(a, b) for a, b in zip(got, last))
        for t, k in ((ds.time[0], 0), (130.0, 2)):  # a time: the nearest snapshot
            got, want = outlines_at(ds, t), [p.copy() for p in outlines_at(ds, k)]
            assert all(np.array_equal(a, b) for a, b in zip(got, want))
        with pytest.raises(IndexError, match=r"snapshot 99 is out of range: the dataset has 6 "
                                             r"snapshots \(0 to 5, or -1 for the last\)"):
            outlines_at(ds, 99)



def test_a_sweep_may_give_durations_as_numbers_of_seconds(tmp_path):
    """In a sweep file, as in a scene file, a number is seconds: only the command line asks
    for the unit."""
    from siku_io.ensemble.sweep import sweep_from_text

    (tmp_path / "base.toml").write_text(GOOD, encoding="utf-8")
    sw = sweep_from_text('scene = "base.toml"\n[[axis]]\nkey = "time.dt"\nvalues = [30, 60.0]\n',
                         "sweep.toml", tmp_path)
    assert len(sw.members) == 2
