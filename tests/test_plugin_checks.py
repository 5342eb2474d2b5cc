"""Load-time checks of third-party components: each fault a plugin author can make gets one line
naming the package, the component and the fault, from ``siku plugins`` and from ``siku run``.

An installed package (an entry point) with a faulty component is a warning when the registry is
built and an error only for a scene that uses that component; a module registered explicitly
(``register_module``) is refused at once. A contact law's evaluators are compiled when a run is
built, before step 1.
"""
from __future__ import annotations

import textwrap

import pytest

from siku_core import PluginError
from siku_core.run.cli import main
from siku_core.plugins import register_module
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene
from siku_core.testing.contact_conformance import contact_scene_text

HEAD = '''
import numpy as np
from numba import njit

from siku_core import Param, hookimpl
from siku_core.interfaces import ContactLaw, ForcingSource
from siku_plugins.contact_laws import Collision, DistributedSpring

'''

#: name -> (source after HEAD, the registered name, the kind, expected message parts)
FAULTS = {
    "plain_number": ('''
class Push(ForcingSource):
    """A constant push."""

    name = "push_plain"
    params = {"force": 5.0}

    def add(self, t, q, V, w, F, T):
        F[:, 0] += self.p["force"]


@hookimpl
def siku_register_forcing_sources():
    return [Push]
''', "push_plain", "forcing",
        ["forcing 'push_plain' from package 'faulty-ice'", "parameter 'force' is 5.0 (float)",
         "not a siku_core.Param"]),
    "no_unit": ('''
class Push(ForcingSource):
    """A constant push."""

    name = "push_unitless"
    params = {"force": Param(5.0, "", "push [N]")}

    def add(self, t, q, V, w, F, T):
        F[:, 0] += self.p["force"]


@hookimpl
def siku_register_forcing_sources():
    return [Push]
''', "push_unitless", "forcing",
        ["forcing 'push_unitless' from package 'faulty-ice'", "parameter 'force' has no unit",
         "'1' for a dimensionless number"]),
    "no_evaluator": ('''
class Bare(ContactLaw):
    """No evaluator."""

    name = "bare_law"

    def collision_parameters(self):
        return np.zeros(1)


@hookimpl
def siku_register_contact_laws():
    return [Bare]
''', "bare_law", "contact_law",
        ["contact law 'bare_law' from package 'faulty-ice'", "no collision_evaluator",
         "subclassing the law registered as 'collision'"]),
    "not_jitted": ('''
def plain(g, pars, hist, out):
    out[0] = 1.0


class Plain(DistributedSpring):
    """A joint evaluator that is a plain function."""

    name = "plain_law"
    joint_evaluator = plain


@hookimpl
def siku_register_contact_laws():
    return [Plain]
''', "plain_law", "contact_law",
        ["contact law 'plain_law' from package 'faulty-ice'", "joint_evaluator is <function",
         "not a numba @njit function"]),
    "wrong_arity": ('''
@njit
def three(g, pars, out):
    out[0] = 1.0


class Three(DistributedSpring):
    """A joint evaluator without hist."""

    name = "three_law"
    joint_evaluator = three


@hookimpl
def siku_register_contact_laws():
    return [Three]
''', "three_law", "contact_law",
        ["contact law 'three_law' from package 'faulty-ice'",
         "joint_evaluator three(g, pars, out) takes 3 parameters, expected 4: "
         "(g, pars, hist, out)"]),
}

#: compiles at registration (right names, jitted) but not for the engine's arguments
MISTYPED = '''
@njit
def mistyped(g, pars, out):
    out[0] = g  # an array into a float
    out[1] = 0.0
    out[2] = 0.0


class Mistyped(Collision):
    """An evaluator that does not type."""

    name = "mistyped_law"
    collision_evaluator = mistyped


@hookimpl
def siku_register_contact_laws():
    return [Mistyped]
'''


def _install(siku_fake_install, source, name="faulty-ice", module="faulty_ice"):
    with pytest.warns(UserWarning) as rec:
        reg = siku_fake_install(name, "0.2", {"faulty": module},
                                modules={module: HEAD + textwrap.dedent(source)})
    return reg, [str(w.message) for w in rec]


def _scene_for(kind, name):
    if kind == "forcing":
        return make_scene(forcing=[{"source": name}])
    from siku_core.scene.scene_file import scene_from_text

    return scene_from_text(contact_scene_text(name, elements=[(10.0, 70.0)]), "<t>")


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_faulty_installed_component_warns_lists_and_fails_only_where_used(
        fault, siku_fake_install, capsys):
    source, name, kind, parts = FAULTS[fault]
    reg, warned = _install(siku_fake_install, source)
    assert any(all(p in w for p in parts) for w in warned), warned
    assert name not in reg.names(kind)
    # other runs are unaffected
    Simulation(make_scene(), out=False, progress=False).run(steps=1)
    # siku plugins lists it as refused, on one line, and exits 0
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    line = [ln for ln in out.splitlines() if ln.startswith("refused:")]
    assert len(line) == 1 and all(p in line[0] for p in parts), out
    # a scene that uses it: one line naming the table, the package, the component, the fault
    with pytest.raises(PluginError) as ei:
        Simulation(_scene_for(kind, name), out=False, progress=False)
    msg = str(ei.value)
    assert "\n" not in msg and all(p in msg for p in parts), msg
    assert ("[forcing[0]]" if kind == "forcing" else "[contact]") in msg


def test_faulty_component_in_a_run_from_the_command_line_exits_2_with_one_line(
        siku_fake_install, tmp_path, monkeypatch, capsys):
    source, name, kind, parts = FAULTS["plain_number"]
    _install(siku_fake_install, source)
    from siku_core.testing import scene_text

    scene = tmp_path / "push.toml"
    scene.write_text(scene_text(forcing=[{"source": name}]))
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(scene), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("siku: error:")
    assert all(p in err for p in parts), err


def test_explicitly_registered_faulty_module_is_refused_at_once(tmp_path, monkeypatch):
    source, name, kind, parts = FAULTS["no_unit"]
    (tmp_path / "faulty_direct.py").write_text(HEAD + textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    import faulty_direct

    with pytest.raises(PluginError) as ei:
        register_module(faulty_direct)
    assert "forcing 'push_unitless' from package 'faulty_direct'" in str(ei.value)
    assert "parameter 'force' has no unit" in str(ei.value)


def test_an_evaluator_that_does_not_compile_is_refused_before_step_1(siku_fake_install):
    """Registration passes (jitted, right parameters); building a run compiles it for the
    engine's argument types and refuses it with numba's reason on one line."""
    reg = siku_fake_install("typo-ice", "0.1", {"typo": "typo_ice"},
                            modules={"typo_ice": HEAD + MISTYPED})
    assert "mistyped_law" in reg.names("contact_law")
    with pytest.raises(PluginError) as ei:
        Simulation(_scene_for("contact_law", "mistyped_law"), out=False, progress=False)
    msg = str(ei.value)
    assert "\n" not in msg, msg
    assert msg.startswith("contact law 'mistyped_law' from package 'typo-ice': "
                          "collision_evaluator mistyped(g, pars, out) does not compile for "
                          "float64 arrays: "), msg
    assert "float64" in msg.split("float64 arrays: ", 1)[1]  # numba's reason names the types


INTERNAL_FIELD = '''
from siku_core.interfaces import Field
from siku_forcing.drag import AirDrag


class Breeze(Field):
    """A steady 5 m/s east wind (the plugin's own field, not registered)."""

    name = "breeze_field"

    def sample(self, t, lat, lon):
        return np.full(len(lat), 5.0), np.zeros(len(lat))


class SteadyBreeze(AirDrag):
    """Air drag of a steady breeze built inside the source (no field table)."""

    name = "steady_breeze"
    uses_field = False

    def setup(self, ctx):
        self.field = Breeze()
        super().setup(ctx)


@hookimpl
def siku_register_forcing_sources():
    return [SteadyBreeze]
'''


def test_a_component_built_inside_a_plugin_is_recorded_under_its_package(siku_fake_install):
    reg = siku_fake_install("breeze-ice", "0.4", {"breeze": "breeze_ice"},
                            modules={"breeze_ice": HEAD + INTERNAL_FIELD})
    assert "steady_breeze" in reg.names("forcing")
    sim = Simulation(make_scene(forcing=[{"source": "steady_breeze"}]), out=False,
                     progress=False)
    sim.run(steps=1)
    versions = sim.plugin_versions()
    assert versions.get("breeze-ice") == "0.4"
    assert "unknown" not in versions.values(), versions
    assert any(type(c).__name__ == "Breeze" for c in sim.components())
    assert sim.state.F[:, 0].any()  # the breeze pushed
