"""Every optional capability of a component is declared on its base class, with a typed default
and a docstring (``siku_core.component``, ``siku_core.interfaces``, ``siku_core.contact_law``),
and the engine and siku's writers read it as an attribute: no ``getattr(comp, "x", default)`` or
``hasattr(comp, "x")`` probes a component.

The scan lists every ``getattr``/``hasattr`` with a literal name in ``siku_core`` and
``siku_io``; each must be one of :data:`ALLOWED` (what it reads, and why it is no component's
capability). A new probe fails here: declare the capability on the base class and read it, or,
for an object that is not a component, add it below with the reason.
"""
from __future__ import annotations

import ast
import inspect
from pathlib import Path

from siku_core.component import Component
from siku_core.interfaces import KINDS, Writer

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_io")

#: (file, name) -> what is probed; none of them is a component
ALLOWED: dict[tuple[str, str], str] = {
    ("siku_core/contact/contact_joints.py", "arms"): "the joint table's own optional column",
    ("siku_core/contact/contact_model.py", "ji"): "the contact model before its joints are built",
    ("siku_core/ranks/driver.py", "loc"): "the rank driver before its local run exists",
    ("siku_core/contact_law.py", "__func__"): "a staticmethod wrapper of an evaluator",
    ("siku_core/contact_law.py", "py_func"): "whether an evaluator is a numba dispatcher",
    ("siku_core/contact_law.py", "compile"): "whether an evaluator is a numba dispatcher",
    ("siku_core/contact_law.py", "_can_compile"): "a numba dispatcher's explicit signatures",
    ("siku_core/testing/contact_energy_checks.py", "__func__"): "a staticmethod wrapper",
    ("siku_core/contact/kernel_cache.py", "py_func"): "module members that are numba dispatchers",
    ("siku_core/contact/kernel_cache.py", "__module__"): "the module of a dispatcher's function",
    ("siku_core/run/progress.py", "py_func"): "a numba dispatcher",
    ("siku_core/numba_cache.py", "CACHE_LOCATOR_CLASSES"): "numba's cache locators (its version)",
    ("siku_core/numba_cache.py", "_locator_classes"): "numba's cache locators (its version)",
    ("siku_core/parallel.py", "_get_num_threads"): "numba's threading layer",
    ("siku_core/plugins.py", "name"): "a registered object refused before it is known to be a "
                                      "component class (it may subclass nothing)",
    ("siku_core/plugins.py", "__qualname__"): "the same refused object",
    ("siku_core/plugins.py", "__isabstractmethod__"): "a required method left abstract",
    ("siku_core/plugins.py", "__version__"): "a plugin's top-level module",
    ("siku_core/plugins.py", "__name__"): "a pluggy hook implementation's plugin",
    ("siku_core/records.py", "dtype"): "a value given for a record's field",
    ("siku_core/scene/scene_api.py", "dtype"): "a numpy scalar in a scene dictionary",
    ("siku_core/scene/scene_api.py", "ndim"): "a numpy scalar in a scene dictionary",
    ("siku_core/scene/scene_api.py", "tolist"): "a numpy array in a scene dictionary",
    ("siku_core/scene/scene_messages.py", "func"): "a pydantic validator",
    ("siku_core/scene/scene_messages.py", "metadata"): "a typing.Annotated argument",
    ("siku_core/run/summary.py", "start"): "the scene's [time] table",
    ("siku_core/run/summary.py", "compile_seconds"): "the simulation (not a component)",
    ("siku_core/testing/element_source_checks.py", "label"): "what a source's build returned",
    ("siku_io/ensemble/runs.py", "sweep_out_dir"): "a NetCDF file's global attributes",
    ("siku_io/ensemble/runs.py", "sweep"): "a NetCDF file's global attributes",
    ("siku_io/ensemble/runs.py", "scene"): "a NetCDF file's global attributes",
    ("siku_io/mesh/gshhg.py", "geoms"): "a shapely geometry",
    ("siku_io/output/hdf5.py", "items"): "an h5py group or dataset",
    ("siku_io/output/marks.py", "fork"): "the os module (POSIX)",
    ("siku_io/output/xr.py", "values"): "an xarray DataArray or a plain value",
    ("siku_io/output/xr.py", "item"): "a numpy scalar attribute",
    ("siku_io/output/zarr_read.py", "members"): "a Zarr group or array",
    ("siku_io/output/zarr_store.py", "tolist"): "a numpy attribute value",
}


def probes() -> dict[tuple[str, str], list[int]]:
    """``{(file, name): [line, ...]}`` of every ``getattr(x, "name", ...)`` and
    ``hasattr(x, "name")`` in the packages."""
    found: dict[tuple[str, str], list[int]] = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                        and node.func.id in ("getattr", "hasattr") and len(node.args) >= 2
                        and isinstance(node.args[1], ast.Constant)
                        and isinstance(node.args[1].value, str)):
                    key = (path.relative_to(ROOT).as_posix(), node.args[1].value)
                    found.setdefault(key, []).append(node.lineno)
    return found


def capabilities() -> set[str]:
    """Every attribute the base classes of the kinds declare (their own and Component's)."""
    out: set[str] = set()
    for base in (Component, *KINDS.values()):
        out |= {n for n in vars(base) if not n.startswith("__")}
        out |= set(getattr(base, "__annotations__", {}))
    return out


def test_no_component_capability_is_probed():
    found = probes()
    new = {f"{f}:{lines[0]} {name!r}" for (f, name), lines in found.items()
           if (f, name) not in ALLOWED}
    assert not new, (f"getattr/hasattr with a literal name: {sorted(new)}; declare the "
                     "capability on the component's base class with a typed default and "
                     "read it, or list what is probed in ALLOWED with the reason")
    stale = set(ALLOWED) - set(found)
    assert not stale, f"ALLOWED lists probes the code no longer has: {sorted(stale)}"
    caps = capabilities()
    # a name the bases declare is read as an attribute, except where the object may not be a
    # component yet (a registration refused before the subclass check)
    probed = {name for (f, name) in ALLOWED if name in caps and f != "siku_core/plugins.py"}
    assert not probed, f"declared capabilities probed: {sorted(probed)}"


def test_the_capabilities_the_engine_reads_are_declared_with_typed_defaults_and_documented():
    """What the engine once probed is now declared: a class-level default, a type, a comment
    or docstring on the base (``#:`` lines are read here from the source)."""
    wanted = {
        Component: ("runs_on_ranks", "ranks_refusal", "integrates", "owned_fields",
                    "optional_fields", "diagnostic_units", "table"),
        Writer: ("in_memory", "folder", "overwrite", "appends", "target", "published", "lock"),
        KINDS["contact_law"]: ("contact_history_names", "history_update", "collision_evaluator",
                               "joint_evaluator", "joint_energy", "collision_record",
                               "joint_record"),
        KINDS["element_source"]: ("table_model",),
    }
    for base, names in wanted.items():
        hints = {}  # the annotations as written (some name types only under TYPE_CHECKING)
        for klass in reversed(base.__mro__):
            hints.update(vars(klass).get("__annotations__", {}))
        lines = inspect.getsource(base).splitlines()
        for name in names:
            assert name in vars(base), (base.__name__, name)  # a default on the base itself
            assert name in hints, (base.__name__, name)
            at = next(i for i, ln in enumerate(lines) if ln.startswith(f"    {name}:"))
            assert lines[at - 1].startswith("    #: "), (base.__name__, name, "no #: comment")
    for base, meth in ((Writer, "holds_snapshots"), (Writer, "_discard"),
                       (KINDS["process"], "couple_exchange")):
        assert getattr(base, meth).__doc__, (base.__name__, meth)


def test_a_component_without_the_optional_capabilities_runs_with_their_defaults():
    """A process that declares none of them: the engine's reads give the base's defaults."""
    from siku_core.run.guard import integrated_fields
    from siku_core.ranks.driver import refusal_reason

    class _Plain(KINDS["process"]):
        name = "plain"

        def apply(self, ctx, dt):
            pass

    p = _Plain()
    assert p.integrates == {} and p.optional_fields == () and p.couple_exchange(None) is None
    assert "element-local" in refusal_reason(p)  # a process is not element-local by default

    class _Sim:
        processes = ()
        state = type("S", (), {"thickness": None})()

        def components(self):
            return [p]

    assert integrated_fields(_Sim()) == []
