"""Plugins: name lookup, registration checks, entry points, the example plugin, conformance."""
from __future__ import annotations

import os
import subprocess
import sys
import types
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from siku_core import PluginError, hookimpl
from siku_core.interfaces import ForcingSource, Integrator
from siku_core.plugins import get_registry, make_plugin_manager, register_module
from siku_core.run.simulation import Simulation
from siku_core.testing import conformance, make_scene

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "siku_example_plugin"
EXAMPLE_SCENE = EXAMPLE / "scenes" / "tilt_drift.toml"


def plugin_module(name: str, **hooks) -> types.ModuleType:
    """A plugin module object called ``name`` implementing the given hooks."""
    mod = types.ModuleType(name)
    for hook, fn in hooks.items():
        fn.__name__ = hook
        setattr(mod, hook, hookimpl(fn))
    return mod


@pytest.fixture
def install_example(siku_fake_install):
    """The example plugin 'installed' through a dist-info folder and its entry point."""
    return lambda: siku_fake_install(
        "siku-example-plugin", "0.1", {"example": "siku_example_plugin.plugin"},
        paths=[EXAMPLE], top_level=["siku_example_plugin"])


# ---------------------------------------------------------------------------- name lookup
def test_unknown_name_lists_the_known_names():
    with pytest.raises(PluginError) as ei:
        get_registry().get("integrator", "eulr")
    msg = str(ei.value)
    assert "unknown integrator 'eulr'" in msg
    assert "rk4" in msg and "siku2" in msg


def test_unknown_name_in_a_scene_names_the_table_and_known_names():
    scene = make_scene(forcing=[{"source": "wind_drag"}])
    with pytest.raises(PluginError, match=r"\[forcing\[0\]\]: unknown forcing 'wind_drag'; "
                                          r"known: .*air_drag.*coriolis.*water_drag"):
        Simulation(scene, out=False)


def test_module_class_path_works_instead_of_a_name():
    scene = make_scene(integrator="siku_plugins.integrators:RK4",
                       forcing=[{"source": "siku_forcing.drag:Coriolis"}])
    sim = Simulation(scene, out=False, progress=False)
    assert type(sim.integrator).__name__ == "RK4"
    assert sim.forcing[0].name == "coriolis"
    sim.run(steps=2)


def test_bad_module_class_paths_are_errors_naming_the_path():
    with pytest.raises(PluginError,
                       match="cannot import integrator 'siku_plugins.integrators:Nope'"):
        get_registry().get("integrator", "siku_plugins.integrators:Nope")
    with pytest.raises(PluginError, match="does not subclass siku_core.interfaces.Integrator"):
        get_registry().get("integrator", "siku_forcing.drag:Coriolis")


# ---------------------------------------------------------------------------- registration
class _Twin(Integrator):
    """An integrator whose name collides."""

    name = "twin"

    def step(self, state, t, dt, forces):
        forces(t, state.q, state.V, state.w, state.F, state.T)


TWIN_SOURCE = '''
from siku_core import hookimpl
from siku_core.interfaces import Integrator


class Twin(Integrator):
    """An integrator named twin."""

    name = "twin"

    def step(self, state, t, dt, forces):
        pass


@hookimpl
def siku_register_integrators():
    return [Twin]
'''


def test_duplicate_name_from_two_packages_warns_and_fails_only_scenes_that_use_it(
        siku_fake_install):
    """Two installed packages register 'twin': a warning naming both, every other run still
    works, a scene that says 'twin' gets one line naming both packages and the way out (the
    class path), and the class path runs."""
    siku_fake_install("alpha-ice", "1.0", {"alpha": "alpha_ice"},
                      modules={"alpha_ice": TWIN_SOURCE})
    with pytest.warns(UserWarning) as rec:
        reg = siku_fake_install("beta-ice", "2.0", {"beta": "beta_ice"},
                                modules={"beta_ice": TWIN_SOURCE})
    msgs = [str(w.message) for w in rec if "duplicate integrator name 'twin'" in str(w.message)]
    assert msgs and "'alpha-ice'" in msgs[0] and "'beta-ice'" in msgs[0]
    Simulation(make_scene(), out=False, progress=False).run(steps=1)  # runs without 'twin'
    with pytest.raises(PluginError) as ei:
        Simulation(make_scene(integrator="twin"), out=False, progress=False)
    msg = str(ei.value)
    assert "\n" not in msg and "[integrator]" in msg
    assert "'alpha-ice' (alpha_ice:Twin)" in msg and "'beta-ice' (beta_ice:Twin)" in msg
    assert ("'alpha_ice:Twin' or 'beta_ice:Twin'" in msg
            or "'beta_ice:Twin' or 'alpha_ice:Twin'" in msg)
    sim = Simulation(make_scene(integrator="beta_ice:Twin"), out=False, progress=False)
    sim.run(steps=1)
    assert sim.plugin_versions()["beta-ice"] == "2.0"
    assert reg.ambiguous


def test_duplicate_of_a_builtin_name_is_an_error_naming_both_packages():
    class Mine(_Twin):
        name = "siku2"

    mod = plugin_module("my_ice_pkg", siku_register_integrators=lambda: [Mine])
    with pytest.raises(PluginError, match=r"'siku2'.*package 'siku' \(siku_plugins.integrators:"
                                          r"Siku2\) and by package 'my_ice_pkg'"):
        make_plugin_manager(extra=(mod,))


def test_wrong_parameter_name_fails_at_registration_naming_the_parameter():
    class Misnamed(ForcingSource):
        """Torque argument misnamed."""

        name = "misnamed"

        def add(self, t, q, V, w, F, torque):
            pass

    mod = plugin_module("misnamed_pkg", siku_register_forcing_sources=lambda: [Misnamed])
    with pytest.raises(PluginError) as ei:
        register_module(mod)
    msg = str(ei.value)
    assert "forcing 'misnamed' from package 'misnamed_pkg'" in msg
    assert "parameter 6 is 'torque', expected 'T'" in msg
    assert "add(t, q, V, w, F, T)" in msg
    # the failed module is not left behind: later runs still work
    assert "misnamed" not in get_registry().names("forcing")
    Simulation(make_scene(), out=False, progress=False).run(steps=1)


def test_missing_method_fails_at_registration():
    class NoStep(Integrator):
        name = "nostep"

    mod = plugin_module("nostep_pkg", siku_register_integrators=lambda: [NoStep])
    with pytest.raises(PluginError, match="integrator 'nostep' from package 'nostep_pkg' does "
                                          r"not implement step\(\)"):
        make_plugin_manager(extra=(mod,))


def test_hookimpl_without_a_spec_is_an_error():
    mod = plugin_module("typo_pkg", siku_register_integrator=lambda: ())
    with pytest.raises(PluginError, match="hook without a specification.*siku_register_integrator"):
        register_module(mod)
    assert get_registry().names("integrator")  # registry rebuilt without it


BROKEN_SOURCE = "raise ImportError('needs the library libfloe, which is not installed')\n"


def test_broken_entry_point_plugin_warns_naming_its_package_and_runs_still_work(
    siku_fake_install,
):
    with pytest.warns(UserWarning, match="from package 'broken-floes' failed to load: needs "
                                         "the library libfloe"):
        reg = siku_fake_install("broken-floes", "0.3", {"broken": "broken_floes"},
                                modules={"broken_floes": BROKEN_SOURCE})
    assert "broken-floes" in reg.broken
    sim = Simulation(make_scene(forcing=[{"source": "coriolis"}]), out=False, progress=False)
    sim.run()
    assert sim.step_index == sim.n_steps
    # it becomes an error only when a scene asks for a name it might have provided
    with pytest.raises(PluginError, match="plugins that failed to load: broken-floes"):
        Simulation(make_scene(integrator="floe_leapfrog"), out=False)


def test_disable_autoload_skips_entry_points_but_keeps_builtins(install_example, monkeypatch):
    monkeypatch.setenv("SIKU_DISABLE_PLUGIN_AUTOLOAD", "1")
    reg = install_example()
    assert "euler" not in reg.names("integrator")
    assert "sea_surface_tilt" not in reg.names("forcing")
    assert {"siku2", "rk4"} <= set(reg.names("integrator"))
    assert {"air_drag", "water_drag", "coriolis"} <= set(reg.names("forcing"))
    monkeypatch.delenv("SIKU_DISABLE_PLUGIN_AUTOLOAD")
    reg = get_registry(refresh=True)
    assert "euler" in reg.names("integrator")


def test_the_suite_sees_only_siku_own_components():
    """Whatever plugins the user installed, the suite's registry holds siku's own (conftest
    names the others in SIKU_SKIP_PLUGINS, which the commands the tests start inherit)."""
    assert set(get_registry(refresh=True).plugins) == {"siku"}
    r = subprocess.run([sys.executable, "-c", "from siku_core.plugins import get_registry; "
                        "print(sorted(get_registry().plugins))"],
                       capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout.strip() == "['siku']"


def test_skip_plugins_skips_only_the_named_distribution(install_example, monkeypatch):
    assert "euler" in install_example().names("integrator")
    monkeypatch.setenv("SIKU_SKIP_PLUGINS", "other-pkg, Siku_Example.Plugin")
    reg = get_registry(refresh=True)
    assert "euler" not in reg.names("integrator") and "siku-example-plugin" not in reg.plugins
    assert {"siku2", "rk4"} <= set(reg.names("integrator"))
    monkeypatch.setenv("SIKU_SKIP_PLUGINS", "siku")  # siku's own components are never skipped
    assert "siku2" in get_registry(refresh=True).names("integrator")


@pytest.mark.slow
def test_the_plugin_tests_pass_with_the_example_plugin_really_installed(tmp_path):
    """pip installs the example plugin (into a target folder put on the path), then this file's
    tests run in a fresh interpreter that sees it through its entry point."""
    import shutil

    target, source = tmp_path / "site", tmp_path / "example"  # a copy: pip's build/ and
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns(  # egg-info stay out of
        "build", "*.egg-info", "__pycache__", ".benchmarks"))  # the source tree
    r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target",
                        str(target), str(source)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(target), *filter(None, [os.environ.get("PYTHONPATH")])])}
    env.pop("SIKU_SKIP_PLUGINS", None)
    seen = subprocess.run([sys.executable, "-c", "from siku_core.plugins import get_registry; "
                           "print(get_registry().entry('integrator', 'euler').package)"],
                          capture_output=True, text=True, env=env, timeout=120)
    assert seen.stdout.strip() == "siku-example-plugin", seen.stderr[-2000:]
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        "-k", "not Conformance", str(Path(__file__))],
                       capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:]
    assert " passed" in r.stdout and " failed" not in r.stdout


# ---------------------------------------------------------------------------- example plugin
def test_example_plugin_through_its_entry_point_runs_its_scene_by_name(install_example, tmp_path):
    reg = install_example()
    entry = reg.entry("forcing", "sea_surface_tilt")
    assert (entry.package, entry.version) == ("siku-example-plugin", "0.1")
    assert reg.entry("integrator", "euler").package == "siku-example-plugin"
    out = tmp_path / "tilt.h5"
    sim = Simulation(EXAMPLE_SCENE, out=out, progress=False).run()
    assert type(sim.integrator).__module__ == "siku_example_plugin.euler"
    assert np.isfinite(sim.state.V).all() and np.abs(sim.state.V).max() > 1e-3
    with h5py.File(out, "r") as f:
        assert f["plugins"].attrs["siku-example-plugin"] == "0.1"
        assert f["plugins"].attrs["siku"]
        assert f["states/step"][-1] == sim.n_steps


def test_example_plugin_is_gone_after_the_registry_is_rebuilt():
    # runs after the test above: the fake install was undone and the registry rebuilt
    assert "euler" not in get_registry().names("integrator")
    with pytest.raises(PluginError, match="unknown integrator 'euler'"):
        Simulation(EXAMPLE_SCENE, out=False)


def test_example_plugin_passes_its_own_test_suite():
    """The example's tests (siku's conformance suite via the pytest11 fixtures) pass."""
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE)],
        check=False, capture_output=True, text=True, cwd=EXAMPLE, timeout=300,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "passed" in r.stdout


# ---------------------------------------------------------------------------- conformance
class TestBuiltinForcingConformance(conformance.TestForcingSourceConformance):
    """Every registered forcing source and field passes the conformance suite."""


class _Overwrites(ForcingSource):
    """Sets F instead of adding to it."""

    name = "overwrites"

    def add(self, t, q, V, w, F, T):
        F[:] = 1.0


class _DragInStillAir(ForcingSource):
    """A drag that pushes even when the field is zero."""

    name = "bad_drag"
    uses_field = True

    def add(self, t, q, V, w, F, T):
        F[:, 0] += 1.0


class _NaNAtPole(ForcingSource):
    """NaN on elements at the North Pole."""

    name = "nan_at_pole"

    def add(self, t, q, V, w, F, T):
        pole = 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2) > 1 - 1e-12
        F[pole] += np.nan


class _WrongReference(ForcingSource):
    """A py_add reference that disagrees with add."""

    name = "wrong_reference"

    def add(self, t, q, V, w, F, T):
        T[:] += 1.0

    def py_add(self, t, q, V, w, F, T):
        T[:] += 1.5


@pytest.fixture(scope="module")
def bad_registry():
    mod = plugin_module("bad_pkg", siku_register_forcing_sources=lambda: [
        _Overwrites, _DragInStillAir, _NaNAtPole, _WrongReference])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return make_plugin_manager(extra=(mod,))[1]


def test_conformance_catches_a_source_that_overwrites(bad_registry):
    case, = conformance.forcing_cases(bad_registry, sources=["overwrites"])
    with pytest.raises(AssertionError, match="add\\(\\) must add to F, not overwrite it"):
        conformance.check_forcing_only_adds(case, bad_registry)


def test_conformance_catches_stress_in_a_zero_field(bad_registry):
    case = conformance.forcing_cases(bad_registry, sources=["bad_drag"], fields=["uniform"])[0]
    assert case.id == "bad_drag[uniform]"
    with pytest.raises(AssertionError, match="zero field and ice at rest, yet force"):
        conformance.check_forcing_zero_field(case, bad_registry)


def test_conformance_catches_nan_at_the_pole_and_a_wrong_reference(bad_registry):
    case, = conformance.forcing_cases(bad_registry, sources=["nan_at_pole"])
    with pytest.raises(AssertionError, match="non-finite force .* on element 0 at lat 90"):
        conformance.check_forcing_finite(case, bad_registry)
    case, = conformance.forcing_cases(bad_registry, sources=["wrong_reference"])
    assert case.has_py_add
    with pytest.raises(AssertionError, match="compiled T 1.0 != pure-Python 1.5"):
        conformance.check_forcing_matches_python(case, bad_registry)


def test_conformance_cases_pair_every_drag_with_every_field():
    ids = {c.id for c in conformance.forcing_cases()}
    assert {"air_drag[uniform]", "air_drag[cyclone]", "water_drag", "water_drag[uniform]",
            "coriolis"} <= ids
    assert "air_drag" not in ids  # air drag needs a field


# ---------------------------------------------------------------------------- fixtures
def test_fixtures_build_scenes_and_quiet_simulations(siku_scene_factory,
                                                     siku_simulation_factory):
    scene = siku_scene_factory([(0.0, 90.0), (180.0, 0.0)], file=True)
    assert scene.path is not None and scene.path.name == "scene.toml"
    sim = siku_simulation_factory(scene)
    assert sim.writers == [] and sim.output_path is None and sim.progress is False
    assert sim.state.n == 2
    sim = siku_simulation_factory(elements=[(10.0, 60.0)], forcing=[{"source": "coriolis"}])
    assert [f.name for f in sim.forcing] == ["coriolis"]
    assert sim.state.area[0] == pytest.approx(1e8, rel=1e-6)  # 10 km squares


def test_siku_register_fixture_registers_for_one_test(siku_register):
    class Still(ForcingSource):
        """Adds nothing."""

        name = "still"

        def add(self, t, q, V, w, F, T):
            pass

    siku_register(plugin_module("still_pkg", siku_register_forcing_sources=lambda: [Still]))
    assert "still" in get_registry().names("forcing")


def test_siku_register_fixture_cleans_up():
    assert "still" not in get_registry().names("forcing")
