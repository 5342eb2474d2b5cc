"""The progress of ``siku ensemble``: members counted in fractions as their output files grow,
on stderr, off when stderr is not a terminal or with ``--no-progress``."""
from __future__ import annotations

import io
from types import SimpleNamespace

from siku_core.run import cli
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene, scene_text
from siku_io.ensemble import runs as ensemble
from siku_io.ensemble.sweep import toml_value

SCENE = dict(elements=[(-150.0, 75.0)], duration=3600, dt=60, output={"every": "20min"},
             forcing=[{"source": "air_drag", "field": {"type": "uniform",
                                                       "params": {"u": 10.0}}},
                      {"source": "water_drag"}])


def test_a_running_member_counts_the_share_of_its_steps_on_file(tmp_path):
    """A member stopped after 30 of its 60 steps holds its snapshot at step 20: it counts
    20/60 of a member; finished, it counts one."""
    from tqdm import tqdm

    out = tmp_path / "m.h5"
    Simulation(make_scene(**SCENE), out=out, progress=False).run(30)
    assert ensemble.MemberProgress.fraction(out) == 20 / 60
    text = io.StringIO()
    bar = tqdm(total=2, file=text, initial=0, bar_format="{n:.2f}/{total_fmt}")
    results: dict = {}
    jobs = [SimpleNamespace(name="a", output=out),
            SimpleNamespace(name="b", output=tmp_path / "not_yet.h5")]
    watch = ensemble.MemberProgress(bar, jobs, results, interval=0.01)
    assert watch.poll() == 20 / 60
    assert "0.33/2" in text.getvalue()
    results["a"] = {"status": "done"}
    assert watch.poll() == 1.0
    bar.close()
    fresh = tqdm(total=2, file=io.StringIO())
    # members of this process are not read while they write: only finished ones count
    assert ensemble.MemberProgress(fresh, jobs, {}, files=False).poll() == 0.0
    fresh.close()


def _sweep(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(**SCENE), encoding="utf-8")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'scene = {toml_value(str(scene))}\nout_dir = "runs"\n'
                     '[[axis]]\nkey = "run.seed"\nvalues = [1, 2]\n', encoding="utf-8")
    return sweep


def test_ensemble_progress_on_stderr_only_when_asked_or_a_terminal(tmp_path, capsys):
    sweep = _sweep(tmp_path)
    ensemble.run(sweep, scheduler="serial", progress=True, write=False)
    err = capsys.readouterr().err
    assert "2.0/2 members" in err  # the bar, at its end
    # not a terminal (pytest's capture): no bar, the command's own lines only
    assert cli.main(["ensemble", str(sweep), "--scheduler", "serial"]) == 0
    err = capsys.readouterr().err
    assert "members [" not in err and "done in" in err
