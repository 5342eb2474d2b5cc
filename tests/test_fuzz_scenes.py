"""Property-based fuzzing of scene files (hypothesis): every scene ends with exit 0, or exit 2
and one ``siku: error:`` line; never a traceback, never a hang.

Scenes are valid small scenes (polygons with drags, a bonded pack with a contact law, a Voronoi
mesh without land data) mutated at random: values replaced by adversarial ones (NaN, ±inf,
huge, tiny, negative, zero, wrong types, unknown names and file names), keys deleted, unknown
keys added, and now and then the TOML text cut short. Every run is bounded in time; a run past
its budget counts as a hang.

Durations and schedules at their extremes make valid scenes of up to 10⁹ steps (the limit of
``siku_core.run.limits``): such a run is no hang, but would outlast any budget. Every run is bounded
to ``MAX_STEPS`` steps (``Simulation.run`` is asked for no more), so a scene that runs at all
ends; a hang is a run that does not get there within its budget.

The default run tries ``FUZZ_EXAMPLES`` (40) scenes; ``pytest -m slow`` runs the long mode
(``FUZZ_EXAMPLES_LONG``, 500) and prints the count. ``tests/test_fuzz_files.py`` fuzzes sweeps
and damaged output files the same way.
"""
from __future__ import annotations

import contextlib
import copy
import datetime as dt
import io
import os
import signal
import tempfile
import warnings
from pathlib import Path
from typing import Any

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from siku_core.run.cli import main  # noqa: E402
from siku_core.testing.scenes import square, toml_value  # noqa: E402

FUZZ_EXAMPLES = 40
FUZZ_EXAMPLES_LONG = 500
#: wall-clock budget of one run [s]: a valid mutated scene runs at most a few thousand steps of
#: a few elements (a second or two); far past that is a hang
BUDGET = 60.0
#: most steps one fuzzed run takes (a longer valid run is stopped there and counts as run)
MAX_STEPS = 3000

BASES: list[dict[str, Any]] = [
    {"title": "drift", "time": {"start": dt.datetime(2001, 2, 3, tzinfo=dt.timezone.utc),
                                  "duration": 600, "dt": 60},
     "elements": {"polygon": [{"vertices": square((-150.0, 75.0))},
                              {"vertices": square((-149.6, 75.0)), "velocity": [0.1, 0.0]}]},
     "forcing": [{"source": "water_drag"},
                 {"source": "air_drag", "field": {"type": "uniform", "params": {"u": 10.0}}},
                 {"source": "coriolis"}],
     "output": {"every": 120}},
    {"title": "bonded", "time": {"duration": 10, "dt": 0.1},
     "materials": {"ice": {"youngs_modulus": 1e9}},
     "elements": {"pack": [{"lon": [30.0, 30.2], "lat": [72.0, 72.04], "nx": 4, "ny": 2,
                            "left": "static", "right": "steady",
                            "right_velocity": [0.5, 0.0]}]},
     "contact": {"law": "distributed_spring", "params": {"tensile_strain": 2e-4}},
     "run": {"seed": 3}},
    {"title": "mesh", "time": {"duration": 1200, "dt": 60},
     "elements": {"mesh": {"lon": [-150.0, -149.0], "lat": [72.0, 72.3], "spacing": 8e3,
                           "land": "none", "cache": False, "seed": 1}},
     "forcing": [{"source": "water_drag"}]},
    {"title": "cached mesh", "time": {"duration": 600, "dt": 60},
     "elements": {"mesh": {"lon": [-150.0, -149.5], "lat": [72.0, 72.2], "spacing": 6e3,
                           "land": "none", "cache": True, "mesh_file": "m.mesh.npz",
                           "seed": 2, "coast_spacing": 4e3, "coast_distance": 1e4}},
     "forcing": [{"source": "water_drag"}], "output": {"every": 300, "diagnostics_every": 60}},
]

NUMBERS = [0, -1, 1, 3, 0.5, -0.5, 1e-3, 1e-300, 1e300, 1e6, float("nan"), float("inf"),
           float("-inf"), 2**63, -(2**63), 10**30]
STRINGS = ["", "abc", "6h", "-5 min", "1e30d", "nope.nc", "/dev/null", ".", "*.nc", "a\x00b",
           "2001-13-40T00:00:00", "static", "gridded", "collision"]
OTHERS = [True, False, [], [0], [1.0, 2.0, 3.0], [[0.0, 0.0]], {}, {"x": 1}]
ADVERSARIAL = NUMBERS + STRINGS + OTHERS


def paths(obj: Any, prefix: tuple = ()) -> list[tuple]:
    """Every (container path, key) in a nested dict/list."""
    out = []
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) \
        else ()
    for k, v in items:
        out.append(prefix + (k,))
        out.extend(paths(v, prefix + (k,)))
    return out


def at(obj: Any, path: tuple) -> Any:
    for k in path:
        obj = obj[k]
    return obj


@st.composite
def scenes(draw) -> str:
    scene = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3]))):
        where = draw(st.sampled_from(paths(scene)))
        parent, key = at(scene, where[:-1]), where[-1]
        old = parent[key]
        op = draw(st.sampled_from(["scale"] * 6 + ["same"] * 2 + ["any", "delete", "unknown"]))
        if op == "scale" and isinstance(old, (int, float)) and not isinstance(old, bool):
            # a plausible value: the scene often stays valid and runs
            f = draw(st.sampled_from([0.1, 0.5, 0.9, 1.1, 2.0, 10.0, 100.0, -1.0]))
            parent[key] = type(old)(old * f) if isinstance(old, float) else int(old * f)
        elif op in ("same", "scale"):
            # a value of the same kind: the scene stays well-typed more often
            pool = (NUMBERS if isinstance(old, (int, float)) and not isinstance(old, bool)
                    else STRINGS if isinstance(old, str) else ADVERSARIAL)
            parent[key] = copy.deepcopy(draw(st.sampled_from(pool)))
        elif op == "any":
            parent[key] = copy.deepcopy(draw(st.sampled_from(ADVERSARIAL)))
        elif op == "delete" and isinstance(parent, dict):
            del parent[key]
        elif isinstance(parent, dict):
            parent[draw(st.sampled_from(["bogus", "every", "law", "nx", "file"]))] = copy.deepcopy(
                draw(st.sampled_from(ADVERSARIAL)))
    text = "\n".join(f"{k} = {toml_value(v)}" for k, v in scene.items())
    if draw(st.integers(0, 19)) == 0:  # now and then a file cut short
        text = text[:draw(st.integers(0, len(text)))]
    return text


class Hang(Exception):
    pass


def bounded_runs():
    """``Simulation.run`` takes at most :data:`MAX_STEPS` steps while the context is active."""
    from siku_core.run.simulation import Simulation

    run = Simulation.run

    def bounded(self, steps=None):
        left = self.n_steps - self.step_index if steps is None else steps
        return run(self, min(left, MAX_STEPS))

    return _patched(Simulation, "run", bounded)


@contextlib.contextmanager
def _patched(obj, name, value):
    old = getattr(obj, name)
    setattr(obj, name, value)
    try:
        yield
    finally:
        setattr(obj, name, old)


def run_scene(text: str) -> tuple[int, str]:
    """``siku run`` on the scene text in a fresh folder; (exit status, stderr)."""
    return run_main(["run", "scene.toml", "--out", "out.h5", "--no-progress", "--no-plots"],
                    {"scene.toml": text})


def run_main(args: list[str], files: dict[str, str | bytes], after=None) -> tuple[int, str]:
    """``siku ARGS`` (in this process, runs bounded to MAX_STEPS steps) in a fresh folder
    holding ``files``; (exit status, stderr). A run past :data:`BUDGET` raises :class:`Hang`.
    ``after(folder)`` is called before the folder goes."""
    def alarm(signum, frame):
        raise Hang(f"no end after {BUDGET:g} s")

    cwd = os.getcwd()
    err = io.StringIO()
    old = signal.signal(signal.SIGALRM, alarm)
    with tempfile.TemporaryDirectory() as d:
        os.chdir(d)
        for name, content in files.items():
            if isinstance(content, bytes):
                Path(name).write_bytes(content)
            else:
                Path(name).write_text(content, encoding="utf-8")
        signal.setitimer(signal.ITIMER_REAL, BUDGET)
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()), \
                    warnings.catch_warnings(), bounded_runs():
                rc = main(args)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)
            os.chdir(cwd)
        if after is not None:
            after(Path(d))
    return rc, err.getvalue()


def check(text: str) -> int:
    try:
        rc, err = run_scene(text)
    except Hang as exc:
        pytest.fail(f"hang ({exc}) on the scene:\n{text}")
    except Exception as exc:  # noqa: BLE001 - a traceback is the failure this test looks for
        pytest.fail(f"traceback ({type(exc).__name__}: {exc}) on the scene:\n{text}")
    assert rc in (0, 2), (rc, err, text)
    assert "Traceback" not in err, (err, text)
    if rc == 2:
        errors = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
        assert len(errors) == 1, (err, text)
    return rc


COUNT = {"n": 0, 0: 0, 2: 0}


@settings(max_examples=FUZZ_EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(scenes())
def test_fuzzed_scenes_end_with_exit_0_or_a_one_line_error(text):
    check(text)


@pytest.mark.slow
@settings(max_examples=FUZZ_EXAMPLES_LONG, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(scenes())
def test_fuzzed_scenes_long(text):
    COUNT["n"] += 1
    COUNT[check(text)] += 1


@pytest.mark.slow
def test_fuzzed_scenes_long_count(capsys):
    """Runs after the long fuzz test (file order) and reports how many scenes it ran."""
    with capsys.disabled():
        print(f"\nfuzz: {COUNT['n']} generated scenes, none with a traceback or a hang: "
              f"{COUNT[0]} ran to the end (exit 0), {COUNT[2]} refused in one line (exit 2)")
    assert COUNT["n"] >= FUZZ_EXAMPLES_LONG


@pytest.mark.parametrize("time", [{"duration": 6e8, "dt": 60},  # 10⁷ steps: 19 years
                                  {"duration": 1e9, "dt": 1}])  # 10⁹ steps: the limit
def test_19_scenes_of_extreme_duration_end(time):
    """Valid scenes at the extremes of durations and schedules (the fuzzer made them and they
    never ended within any budget) run their first MAX_STEPS steps and end."""
    scene = copy.deepcopy(BASES[0])
    scene["time"] = {**scene["time"], **time}
    scene["output"] = {"every": time["dt"] * 1000, "diagnostics_every": time["dt"]}
    assert check("\n".join(f"{k} = {toml_value(v)}" for k, v in scene.items())) == 0
