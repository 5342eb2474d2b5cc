"""The public surface keeps its word: every name the docs and the examples have ever told
authors to import still imports, from its old place with a :class:`DeprecationWarning` naming
its new home; plugins written against earlier releases pass their own tests; the version and
the plugin API version are declared once and recorded; an incompatible plugin is refused.

The policy: ``CHANGELOG.md`` and ``docs/howto/plugins.md``; the surface:
``docs/reference/api.md``; the aliases: :mod:`siku_core.deprecation`.
"""
from __future__ import annotations

import importlib
import importlib.metadata as md
import importlib.util
import inspect
import os
import re
import shutil
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import pytest

import siku_core
from siku_core import PluginError, hookimpl
from siku_core.interfaces import ForcingSource, Process
from siku_core.params import Param
from siku_core.plugins import check_component
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene
from siku_core.versions import PLUGIN_API_VERSION, api_mismatch

ROOT = Path(__file__).resolve().parents[1]
FROZEN = Path(__file__).resolve().parent / "data" / "frozen_plugins"

#: every ``from MODULE import NAME`` (``-``: ``import MODULE``) of every revision of docs/ and
#: examples/ (the output of tools/import_history.py), with the name's home since it moved
#: (``-``: it never moved). A new import in the docs adds a row here
#: (test_the_list_covers_every_import_in_the_history).
HISTORY = """
siku_core                             -                   -
siku_core                             DataError           -
siku_core                             InputError          -
siku_core                             PLUGIN_API_VERSION  -
siku_core                             Param               -
siku_core                             SceneError          -
siku_core                             SikuError           -
siku_core                             Simulation          -
siku_core                             contact_law         -
siku_core                             hookimpl            -
siku_core.cells                       small_cell_report   siku_core.scene.cells
siku_core.contact                     contact_model       -
siku_core.contact.kernel_cache        user_cache_dir      -
siku_core.contact_law                 BREAK_MODE_MEANINGS -
siku_core.contact_law                 BREAK_SHEAR         -
siku_core.contact_law                 BREAK_TENSION       -
siku_core.contact_law                 BreakMode           -
siku_core.contact_law                 COLLISION_LAYOUT    -
siku_core.contact_law                 ContactLaw          -
siku_core.contact_law                 J_AX                -
siku_core.contact_law                 J_AY                -
siku_core.contact_law                 J_BX                -
siku_core.contact_law                 J_BY                -
siku_core.contact_law                 J_HI                -
siku_core.contact_law                 J_HJ                -
siku_core.contact_law                 J_K                 -
siku_core.contact_law                 J_MEFF              -
siku_core.contact_law                 J_S1X               -
siku_core.contact_law                 J_S1Y               -
siku_core.contact_law                 J_S2X               -
siku_core.contact_law                 J_S2Y               -
siku_core.contact_law                 J_SIZE              -
siku_core.contact_law                 J_VAX               -
siku_core.contact_law                 J_VAY               -
siku_core.contact_law                 J_VBX               -
siku_core.contact_law                 J_VBY               -
siku_core.contact_law                 J_W                 -
siku_core.contact_law                 OUT_BREAK           -
siku_core.contact_law                 ParameterRecord     -
siku_core.contact_law                 check_contact_law   -
siku_core.contacts                    BREAK_SHEAR         siku_core.contact_law
siku_core.contacts                    BREAK_TENSION       siku_core.contact_law
siku_core.contacts                    J_AX                siku_core.contact_law
siku_core.contacts                    J_AY                siku_core.contact_law
siku_core.contacts                    J_BX                siku_core.contact_law
siku_core.contacts                    J_BY                siku_core.contact_law
siku_core.contacts                    J_HI                siku_core.contact_law
siku_core.contacts                    J_HJ                siku_core.contact_law
siku_core.contacts                    J_K                 siku_core.contact_law
siku_core.contacts                    J_MEFF              siku_core.contact_law
siku_core.contacts                    J_S1X               siku_core.contact_law
siku_core.contacts                    J_S1Y               siku_core.contact_law
siku_core.contacts                    J_S2X               siku_core.contact_law
siku_core.contacts                    J_S2Y               siku_core.contact_law
siku_core.contacts                    J_VAX               siku_core.contact_law
siku_core.contacts                    J_VAY               siku_core.contact_law
siku_core.contacts                    J_VBX               siku_core.contact_law
siku_core.contacts                    J_VBY               siku_core.contact_law
siku_core.contacts                    J_W                 siku_core.contact_law
siku_core.diagnostics                 catalogue           -
siku_core.errors                      InputError          -
siku_core.errors                      SikuError           -
siku_core.fields                      ENGINE_FIELDS       -
siku_core.fields                      ElementField        -
siku_core.fields                      catalogue           -
siku_core.geometry.element_geometry   east_north          -
siku_core.geometry.element_geometry   polygons_lonlat     -
siku_core.geometry.quat               east_north_local    -
siku_core.geometry.quat               latlon_of           -
siku_core.ice                         ElementField        siku_core.fields
siku_core.interfaces                  AttenuationLaw      -
siku_core.interfaces                  ElementSource       -
siku_core.interfaces                  ElementSpec         -
siku_core.interfaces                  ForcingSource       -
siku_core.interfaces                  Integrator          -
siku_core.interfaces                  Process             -
siku_core.interfaces                  Writer              -
siku_core.kernel_cache                user_cache_dir      siku_core.contact.kernel_cache
siku_core.outputs                     partial_path        siku_core.run.outputs
siku_core.outputs                     publish             siku_core.run.outputs
siku_core.outputs                     settle              siku_core.run.outputs
siku_core.params                      Param               -
siku_core.plugins                     get_registry        -
siku_core.plugins                     register_module     -
siku_core.plugins                     unregister_module   -
siku_core.run.outputs                 partial_path        -
siku_core.run.outputs                 publish             -
siku_core.run.outputs                 settle              -
siku_core.run.simulation              Simulation          -
siku_core.scene                       load_scene          siku_core.scene.scene_file
siku_core.scene                       scene_from_text     siku_core.scene.scene_file
siku_core.scene.cells                 small_cell_report   -
siku_core.scene.scene_api             SceneBuilder        -
siku_core.scene.scene_file            load_scene          -
siku_core.scene.scene_file            scene_from_text     -
siku_core.scene_api                   SceneBuilder        siku_core.scene.scene_api
siku_core.simulation                  Simulation          siku_core.run.simulation
siku_core.state                       FREE                -
siku_core.state                       MELTED              -
siku_core.state                       STATIC              -
siku_core.testing                     conformance         -
siku_core.testing                     make_scene          -
siku_core.testing                     scene_text          -
siku_core.testing.contact_cases       square_pack         -
siku_core.testing.contact_conformance check_contact_law   -
siku_core.testing.contact_conformance collision_geometry  -
siku_core.testing.contact_conformance contact_history_row -
siku_core.testing.element_source_checks check_element_source -
siku_core.testing.process_checks      check_process       -
siku_core.testing.writer_checks       DT                  -
siku_core.testing.writer_checks       check_writer        -
siku_forcing.attenuation              Meylan2014          siku_forcing.waves.attenuation
siku_forcing.gridded.regular_grid     GridCfg             -
siku_forcing.spectral_transport       steady_ratio        siku_forcing.waves.spectral_transport
siku_forcing.synthetic                write_ncep_pair     -
siku_forcing.waves.attenuation        Meylan2014          -
siku_forcing.waves.spectral_transport steady_ratio        -
siku_io                               ensemble            -
siku_io.analysis.fsd                  distribution        -
siku_io.analysis.fsd                  floe_areas          -
siku_io.analysis.fsd                  floe_labels         -
siku_io.analysis.fsd                  output_distribution -
siku_io.analysis.fsd                  tail_fit            -
siku_io.analysis.gridded_fields       grid_output         -
siku_io.analysis.regular_grid         GridCfg             siku_forcing.gridded.regular_grid
siku_io.bmi                           SikuBmi             siku_io.coupling.bmi
siku_io.coupling.bmi                  SikuBmi             -
siku_io.ensemble                      runs                -
siku_io.mesh                          COAST               siku_io.mesh.mesh_file
siku_io.mesh                          ICE                 siku_io.mesh.mesh_file
siku_io.mesh                          Mesh                siku_io.mesh.mesh_file
siku_io.mesh                          MeshParams          siku_io.mesh.params
siku_io.mesh                          build_mesh          siku_io.mesh.build
siku_io.mesh                          load_or_build       siku_io.mesh.cache
siku_io.mesh.build                    build_mesh          -
siku_io.mesh.cache                    load_or_build       -
siku_io.mesh.mesh_file                COAST               -
siku_io.mesh.mesh_file                ICE                 -
siku_io.mesh.mesh_file                Mesh                -
siku_io.mesh.params                   MeshParams          -
siku_io.output.element_geometry       east_north          siku_core.geometry.element_geometry
siku_io.output.element_geometry       polygons_lonlat     siku_core.geometry.element_geometry
siku_io.output.netcdf                 write_netcdf        -
siku_io.output.xr                     outlines_at         -
siku_io.plot                          mapdeco             -
siku_io.plot.element_maps             MapPainter          -
siku_io.plot.element_maps             Output              -
siku_io.plot.element_maps             draw_map            -
siku_io.plot.grid_maps                GridPainter         -
siku_io.plot.grid_maps                draw_grid_map       -
siku_io.xr                            east_north          siku_io.output.xr
siku_plugins.contact_laws             Collision           -
siku_plugins.contact_laws             collision_evaluator -
siku_plugins.floating                 hydro               -
siku_plugins.floating                 memory              -
siku_plugins.floating                 scatter             -
siku_plugins.floating.steady          Steady              -
siku_plugins.floating.steady          thin_plate          -
siku_plugins.lab                      measure             -
"""
ROWS = [tuple(line.split()) for line in HISTORY.strip().splitlines()]
#: what the alias helper says (siku_core.deprecation.warn_moved)
MOVED = "is deprecated: import it from its new home, "


def _tool():
    spec = importlib.util.spec_from_file_location("import_history",
                                                  ROOT / "tools" / "import_history.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _import(module: str, name: str):
    """Run ``from module import name`` (``import module`` for ``-``) as an author's code would;
    return the object and the alias warnings it raised."""
    cached = sys.modules.get(module)
    if cached is not None and cached.__name__ != module:  # a shim that became its new module
        del sys.modules[module]  # so that importing it runs the shim again
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        space: dict = {}
        exec(f"import {module}" if name == "-" else f"from {module} import {name}", space)
    obj = sys.modules[module] if name == "-" else space[name]
    return obj, [w for w in rec if MOVED in str(w.message)]


@pytest.mark.parametrize("module, name, home", ROWS, ids=[" ".join(r[:2]) for r in ROWS])
def test_every_name_the_docs_ever_named_still_imports(module, name, home):
    """At home: no warning. Moved: the same object as at its new home, with a
    DeprecationWarning that names the old path and the new home, attributed to the importing
    line; the new home itself imports without one."""
    obj, warned = _import(module, name)
    if home == "-":
        assert warned == [], [str(w.message) for w in warned]
        return
    shim = sys.modules[module].__name__ != module  # the module moved whole: it names the module
    old = module if name == "-" or shim else f"{module}.{name}"
    new = home if name == "-" or shim else f"{home}.{name}"
    assert warned, f"{old}: no DeprecationWarning"
    for w in warned:
        assert w.category is DeprecationWarning
        assert str(w.message).startswith(f"{old} {MOVED}{new} ("), str(w.message)
        assert w.filename == "<string>", (w.filename, w.lineno)  # the importing statement
    there, again = _import(home, name)
    assert there is obj and again == []


def test_the_list_covers_every_import_in_the_history():
    """tools/import_history.py over the git history finds no import missing from HISTORY."""
    if shutil.which("git") is None or subprocess.run(
            ["git", "rev-parse", "--git-dir"], cwd=ROOT, capture_output=True).returncode:
        pytest.skip("not a git checkout")
    tool = _tool()
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        found = tool.history()
    finally:
        os.chdir(cwd)
    assert found, "no import found in the history of docs/ and examples/"
    missing = sorted(found - {r[:2] for r in ROWS})
    assert missing == [], f"add to HISTORY (with the home of a moved name): {missing}"


def test_a_module_alias_refuses_names_that_never_were():
    with pytest.raises(ImportError, match="siku_core.contacts"):
        exec("from siku_core.contacts import J_NOT_A_NAME", {})
    with pytest.raises(AttributeError, match="J_NOT_A_NAME"):
        importlib.import_module("siku_core.contacts").J_NOT_A_NAME


# ------------------------------------------------------------------ frozen plugins
def _run_frozen(package: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """The frozen package's own tests, in a copy of it, against this tree."""
    copy = tmp_path / package
    shutil.copytree(FROZEN / package, copy)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(copy), str(ROOT)]),
               PYTHONWARNINGS="always::DeprecationWarning")
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider", "-p",
         "no:warnings", "tests"], cwd=copy, env=env, capture_output=True, text=True,
        timeout=3000)


def test_the_example_plugin_as_shipped_with_0_1_passes_its_own_tests(tmp_path):
    """examples/siku_example_plugin as it was before the public surface was declared
    (tests/data/frozen_plugins/siku_example_plugin): its suite passes unchanged, and it uses
    no deprecated name."""
    done = _run_frozen("siku_example_plugin", tmp_path)
    out = done.stdout + done.stderr
    assert done.returncode == 0, out[-4000:]
    assert " passed" in done.stdout and MOVED not in out, out[-4000:]


def test_a_plugin_written_from_the_0_1_guides_passes_its_own_tests_with_warnings(tmp_path):
    """siku-tidal-bonds (tests/data/frozen_plugins/siku_tidal_bonds), written as the plugin
    guides of 0.1 said (the joint layout and break modes from siku_core.contacts,
    joint_parameters(self, sim)): its suite passes, with a DeprecationWarning naming the new
    home of every old name it imports."""
    done = _run_frozen("siku_tidal_bonds", tmp_path)
    out = done.stdout + done.stderr
    assert done.returncode == 0, out[-4000:]
    tool = _tool()
    old = set()
    for path in (FROZEN / "siku_tidal_bonds").rglob("*.py"):
        old |= {(m, n) for m, n in tool.imports_in(path.read_text(encoding="utf-8"))
                if m == "siku_core.contacts"}
    assert len(old) >= 19
    for module, name in sorted(old):
        assert f"{module}.{name} {MOVED}siku_core.contact_law.{name} (" in out, name
    assert "BondedBeam.joint_parameters(self, sim) is deprecated: define joint_parameters(self)" \
        in out


# ------------------------------------------------------------------ versions
def test_the_version_is_read_from_the_distribution_metadata():
    assert siku_core.__version__ == md.version("siku")


def test_the_version_is_semantic_and_has_a_changelog_section():
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert re.fullmatch(r"(0|[1-9]\d*)\.(0|[1-9]\d*)\.(0|[1-9]\d*)", version), version
    log = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert log.startswith("# Changelog")
    assert "## [Unreleased]" in log and f"## [{version}]" in log
    assert "### Deprecated" in log


@pytest.mark.parametrize("requires, why", [
    ("1", ""), ("1.x", ""), ("1.*", ""), (" 1.0 ", ""),
    ("1.1", "older minor version"), ("2.x", "another major version"),
    ("0.x", "another major version"), ("one", "not a plugin API version"),
    (1, "not a plugin API version"),
])
def test_requires_api_against_plugin_api_1_0(requires, why):
    got = api_mismatch(requires, "1.0")
    assert (why in got and got) if why else got == "", got


def test_a_minor_version_serves_what_an_older_minor_asked_for():
    assert api_mismatch("1.2", "1.3") == "" and api_mismatch("1.3", "1.2") != ""


def test_the_plugin_api_version_is_major_minor_and_exported():
    assert re.fullmatch(r"\d+\.\d+", PLUGIN_API_VERSION)
    assert siku_core.PLUGIN_API_VERSION == PLUGIN_API_VERSION
    assert "PLUGIN_API_VERSION" in siku_core.__all__


NEEDS_2 = '''
from siku_core import Param, hookimpl
from siku_core.interfaces import ForcingSource, Process


class Future(ForcingSource):
    """A push from a later plugin API [N]."""

    name = "future_push"
    requires_api = "{requires}"
    params = {{"f": Param(1.0, "N", "push")}}

    def add(self, t, q, V, w, F, T):
        F[:, 0] += self.p["f"]


@hookimpl
def siku_register_forcing_sources():
    return [Future]
'''


def test_an_installed_component_for_another_plugin_api_is_refused_naming_its_package(
        siku_fake_install):
    """One warning naming the package, the component and both versions; the name is not
    registered; a scene that asks for it gets the same one line; other scenes run."""
    with pytest.warns(UserWarning) as rec:
        reg = siku_fake_install("future-ice", "3.0", {"future": "future_ice"},
                                modules={"future_ice": NEEDS_2.format(requires="2.x")})
    text = [str(w.message) for w in rec if "future_push" in str(w.message)]
    assert len(text) == 1 and "package 'future-ice'" in text[0], text
    assert "requires plugin API 2.x" in text[0] and PLUGIN_API_VERSION in text[0]
    assert "future_push" not in reg.names("forcing")
    with pytest.raises(PluginError) as ei:
        Simulation(make_scene(forcing=[{"source": "future_push"}]), out=False, progress=False)
    assert "package 'future-ice'" in str(ei.value) and "\n" not in str(ei.value)


def test_a_component_for_this_plugin_api_registers(siku_register):
    class Now(ForcingSource):
        """A push [N]."""

        name = "push_now"
        requires_api = "1.x"
        params = {"f": Param(1.0, "N", "push")}

        def add(self, t, q, V, w, F, T):
            F[:, 0] += self.p["f"]

    module = type(sys)("push_now_plugin")
    module.siku_register_forcing_sources = hookimpl(lambda: [Now])
    module.siku_register_forcing_sources.__name__ = "siku_register_forcing_sources"
    reg = siku_register(module)
    assert reg.get("forcing", "push_now") is Now


def test_a_0_1_method_that_names_the_context_sim_registers_with_a_warning():
    """siku 0.1's guides named the context ``sim``: ``apply(self, sim, dt)`` is called
    positionally, so it is accepted, with a DeprecationWarning giving the reference form; any
    other name is still refused."""
    class Old(Process):
        """Does nothing."""

        name = "old_process"

        def apply(self, sim, dt):
            pass

    with pytest.warns(DeprecationWarning, match=r"apply\(sim, dt\) is deprecated: write "
                                                r"apply\(ctx, dt\)"):
        check_component("process", Old, "old-ice")

    class Wrong(Process):
        """Does nothing."""

        name = "wrong_process"

        def apply(self, state, dt):
            pass

    with pytest.raises(PluginError, match="parameter 1 is 'state', expected 'ctx'"):
        check_component("process", Wrong, "old-ice")


def test_a_0_1_joint_parameters_with_sim_is_adapted_with_a_warning():
    """A law defining joint_parameters(self, sim) (the 0.1 guides) is adapted to the reference
    form joint_parameters(self), called with sim=None, warning when the class is defined."""
    from siku_core.contact_law import ContactLaw

    with pytest.warns(DeprecationWarning, match=r"Old.joint_parameters\(self, sim\) is "
                                                r"deprecated: define joint_parameters\(self\)"):
        class Old(ContactLaw):
            name = "old_law"

            def joint_parameters(self, sim):
                assert sim is None
                return [1.0, 2.0]

    assert list(inspect.signature(Old.joint_parameters).parameters) == ["self"]
    assert Old.joint_parameters(object.__new__(Old)) == [1.0, 2.0]
