"""Hook specifications, the plugin manager and the component registries.

Every component, the built-in ones included, enters through the same ``pluggy`` hooks and the
same entry points: a package, siku's own distribution as much as a third party's, declares

.. code-block:: toml

    [project.entry-points.siku]
    my_plugin = "my_package.siku_plugin"

and implements hooks with :data:`siku_core.hookimpl`. The engine holds no list of plugin
modules. ``SIKU_DISABLE_PLUGIN_AUTOLOAD=1`` skips the entry points of every other distribution;
those of the distribution that installed ``siku_core`` (the built-in components) still load.
``SIKU_SKIP_PLUGINS=dist-a,dist-b`` skips only the named distributions (a plugin that
misbehaves; siku's own test suite skips every plugin installed before it started, so it passes
whatever a user has installed). A broken third-party plugin becomes a warning naming its
package, and an error only when a scene asks for a name it would have provided. The same holds
for a component that fails the checks made when it registers (its interface, its parameter
declarations, a contact law's evaluators, the plugin API version it ``requires_api``:
:func:`check_component`) and for a name two packages register: a warning, and an error only
for a scene that uses that name. Modules registered
explicitly (:func:`register_module`, ``make_plugin_manager(extra=...)``) and siku's own
components are held to the same checks, but a fault is an error at once.
"""
from __future__ import annotations

import functools
import importlib
import importlib.metadata as md
import inspect
import os
import sys
import warnings
from dataclasses import dataclass, field
from typing import Any, Mapping

import pluggy

from .deprecation import warn_deprecated
from .errors import PluginError
from .fields import ElementField, catalogue
from .interfaces import KINDS, Component
from .params import Param
from .versions import api_mismatch

hookspec = pluggy.HookspecMarker("siku")
hookimpl = pluggy.HookimplMarker("siku")

class SikuHookspecs:
    """Hooks a plugin may implement."""

    @hookspec
    def siku_register_integrators(self) -> list[type]:
        """Return integrator classes."""

    @hookspec
    def siku_register_forcing_sources(self) -> list[type]:
        """Return forcing source classes."""

    @hookspec
    def siku_register_fields(self) -> list[type]:
        """Return velocity field classes (wind, currents)."""

    @hookspec
    def siku_register_broad_phases(self) -> list[type]:
        """Return broad-phase classes."""

    @hookspec
    def siku_register_contact_laws(self) -> list[type]:
        """Return contact law classes."""

    @hookspec
    def siku_register_writers(self) -> list[type]:
        """Return writer classes."""

    @hookspec
    def siku_register_element_sources(self) -> list[type]:
        """Return element source classes (polygon, pack, mesh, floe, ...)."""

    @hookspec
    def siku_register_processes(self) -> list[type]:
        """Return process classes (physics that changes the ice: growth, ridging, ...)."""

    @hookspec
    def siku_register_attenuation_laws(self) -> list[type]:
        """Return attenuation law classes (how sea ice damps waves: the amplitude decay rate
        against frequency and thickness, ``siku_core.interfaces.AttenuationLaw``)."""

    @hookspec
    def siku_register_commands(self, subparsers: Any) -> None:
        """Add ``siku`` subcommands: ``subparsers.add_parser(name, help=...)`` from argparse;
        set ``func`` (``parser.set_defaults(func=fn)``, ``fn(args) -> exit status``)."""

    @hookspec
    def siku_draw(self, path: Any, field: Any) -> list:
        """Draw the pictures of an output file after ``siku run`` (``[output] plots = true``),
        coloured by the per-element ``field`` (``None``: the default); return their paths."""

    @hookspec
    def siku_postprocess(self, path: Any, scene: Any, overwrite: bool) -> list:
        """Derived files of a completed run's output ``path`` (gridded fields of
        ``[output.grid]``...), made after ``siku run``; an existing file is replaced only with
        ``overwrite`` (``--overwrite``); return their paths."""

    @hookspec
    def siku_configured(self, scene: Any) -> None:
        """Called after a scene file is loaded and validated."""

    @hookspec
    def siku_ready(self, simulation: Any) -> None:
        """Called when a simulation is built, before the first step."""

    @hookspec
    def siku_finished(self, simulation: Any) -> None:
        """Called after a run ends (normally or not)."""


_REGISTER_HOOKS = {
    "integrator": "siku_register_integrators",
    "forcing": "siku_register_forcing_sources",
    "field": "siku_register_fields",
    "broad_phase": "siku_register_broad_phases",
    "contact_law": "siku_register_contact_laws",
    "writer": "siku_register_writers",
    "element_source": "siku_register_element_sources",
    "process": "siku_register_processes",
    "attenuation_law": "siku_register_attenuation_laws",
}


@dataclass
class Entry:
    """A registered component and where it came from."""

    cls: type[Component]
    package: str
    version: str


def _path(cls: type) -> str:
    """``package.module:Class``, the name by path a scene may use instead of the name."""
    return f"{cls.__module__}:{cls.__qualname__}"


@dataclass
class Registry:
    """Components of every kind, by name."""

    entries: dict[str, dict[str, Entry]] = field(default_factory=lambda: {k: {} for k in KINDS})
    broken: dict[str, str] = field(default_factory=dict)  # package -> error text
    plugins: dict[str, str] = field(default_factory=dict)  # package -> version
    #: (kind, name) -> why the component was refused when it registered (one line)
    refused: dict[tuple[str, str], str] = field(default_factory=dict)
    #: (kind, name) -> the message of a name registered by two packages
    ambiguous: dict[tuple[str, str], str] = field(default_factory=dict)

    def add(self, kind: str, cls: type, package: str, version: str,
            strict: bool = True) -> None:
        """Register ``cls``. A component that fails :func:`check_component`, or whose name is
        taken by another package's component, is an error when ``strict``; otherwise a warning,
        and an error only when a scene asks for that name (:meth:`get`)."""
        try:
            check_component(kind, cls, package)
        except PluginError as exc:
            if strict:
                raise
            name = str(getattr(cls, "name", "") or getattr(cls, "__qualname__", repr(cls)))
            self.refused[(kind, name)] = str(exc)
            warnings.warn(f"siku: {exc}", stacklevel=3)
            return
        table = self.entries[kind]
        old = table.get(cls.name)
        if old is None or old.cls is cls:
            table[cls.name] = Entry(cls, package, version)
            return
        what = kind.replace("_", " ")
        msg = (
            f"duplicate {what} name '{cls.name}': registered by package '{old.package}' "
            f"({_path(old.cls)}) and by package '{package}' ({_path(cls)})"
        )
        if strict:
            raise PluginError(msg)
        self.ambiguous[(kind, cls.name)] = (
            f"{msg}; name the one to use by its path instead of '{cls.name}': "
            f"'{_path(old.cls)}' or '{_path(cls)}'"
        )
        warnings.warn(f"siku: {msg}; a scene that uses '{cls.name}' must name one by its "
                      "path (package.module:Class)", stacklevel=3)

    def names(self, kind: str) -> list[str]:
        return sorted(self.entries[kind])

    def components(self) -> list[type[Component]]:
        """Every registered component class, kind by kind, by name."""
        return [self.entries[k][n].cls for k in self.entries for n in sorted(self.entries[k])]

    def field_catalogue(self) -> dict[str, ElementField]:
        """``{name: ElementField}`` of every per-element field siku knows: the engine's and
        those the registered components declare (:func:`siku_core.fields.catalogue`)."""
        return catalogue(self.components())

    def get(self, kind: str, name: str, where: str = "") -> type[Component]:
        """Look up a component by registered name or by ``package.module:Class`` path."""
        if ":" in name:
            return self._by_path(kind, name, where)
        if (kind, name) in self.ambiguous:
            raise PluginError(f"{where}{self.ambiguous[(kind, name)]}")
        try:
            return self.entries[kind][name].cls
        except KeyError:
            pass
        if (kind, name) in self.refused:
            raise PluginError(f"{where}{self.refused[(kind, name)]}")
        known = ", ".join(self.names(kind)) or "(none registered)"
        msg = f"{where}unknown {kind.replace('_', ' ')} '{name}'; known: {known}"
        if self.broken:
            msg += "; plugins that failed to load: " + ", ".join(
                f"{p} ({e})" for p, e in self.broken.items()
            )
        raise PluginError(msg)

    def _by_path(self, kind: str, path: str, where: str) -> type[Component]:
        mod_name, _, attr = path.partition(":")
        try:
            obj = getattr(importlib.import_module(mod_name), attr)
        except (ImportError, AttributeError) as exc:
            raise PluginError(f"{where}cannot import {kind} '{path}': {exc}") from None
        try:
            check_component(kind, obj, mod_name)
        except PluginError as exc:
            raise PluginError(f"{where}{exc}") from None
        return obj

    def entry(self, kind: str, name: str) -> Entry | None:
        return self.entries[kind].get(name)


#: parameter types a :class:`~siku_core.params.Param` may declare; ``bool`` and ``str``
#: parameters (switches, names) need no unit, every other one does (``"1"``: dimensionless)
_PARAM_TYPES = (float, int, bool, str, list, dict)


def _check_params(kind: str, cls: Any, package: str) -> None:
    """Every entry of ``params`` a :class:`Param` with a known type and, unless it is a
    ``bool`` or ``str``, a unit."""
    head = f"{kind.replace('_', ' ')} '{cls.name}' from package '{package}'"
    params = cls.params
    if not isinstance(params, Mapping):
        raise PluginError(f"{head}: 'params' is {type(params).__name__}, not a mapping of "
                          "parameter names to siku_core.Param")
    for key, p in params.items():
        if not isinstance(p, Param):
            raise PluginError(
                f"{head}: parameter '{key}' is {p!r} ({type(p).__name__}), not a "
                "siku_core.Param(default, unit, doc)"
            )
        if p.type not in _PARAM_TYPES:
            raise PluginError(
                f"{head}: parameter '{key}' has type {p.type!r}; allowed: "
                + ", ".join(t.__name__ for t in _PARAM_TYPES)
            )
        if p.type not in (bool, str) and not (isinstance(p.unit, str) and p.unit.strip()):
            raise PluginError(
                f"{head}: parameter '{key}' has no unit (unit={p.unit!r}); give its SI unit, "
                "or '1' for a dimensionless number"
            )


def check_component(kind: str, cls: Any, package: str) -> None:
    """Check a component class against its kind's interface (methods and their reference
    signatures), its parameter declarations and, for contact laws, its evaluators; errors are
    one line naming the kind, the component, the package and the fault."""
    base = KINDS[kind]
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise PluginError(
            f"package '{package}' registered {cls!r} as a {kind}, but it does not subclass "
            f"siku_core.interfaces.{base.__name__}"
        )
    if not cls.name or not isinstance(cls.name, str):
        raise PluginError(f"{kind} class {cls.__qualname__} from '{package}' has no 'name'")
    if cls.requires_api is not None and (why := api_mismatch(cls.requires_api)):
        raise PluginError(f"{kind} '{cls.name}' from package '{package}' is refused: {why}")
    for meth, expected in base.required.items():
        fn = getattr(cls, meth, None)
        if fn is None or getattr(fn, "__isabstractmethod__", False):
            raise PluginError(
                f"{kind} '{cls.name}' from package '{package}' does not implement {meth}()"
            )
        got = [p for p in inspect.signature(fn).parameters if p != "self"]
        if len(got) == len(expected) and got != list(expected) and all(
                g == e or (g, e) == ("sim", "ctx") for g, e in zip(got, expected)):
            # siku 0.1 named the run's context "sim": called positionally, it still works
            warn_deprecated(f"{kind} '{cls.name}' from package '{package}': {meth}("
                            f"{', '.join(got)})", f"write {meth}({', '.join(expected)}) (the "
                            "parameter is the run's context, siku_core.context.Context)")
            got = list(expected)
        if tuple(got) != tuple(expected):
            for i, (g, e) in enumerate(zip(got, expected)):
                if g != e:
                    bad = f"parameter {i + 1} is '{g}', expected '{e}'"
                    break
            else:
                bad = f"has parameters {got}, expected {list(expected)}"
            raise PluginError(
                f"{kind} '{cls.name}' from package '{package}': {meth}() {bad} "
                f"(reference signature: {meth}({', '.join(expected)}))"
            )
    _check_params(kind, cls, package)
    if kind == "writer":
        got = [p for p in inspect.signature(cls.read_restart).parameters]
        if not isinstance(inspect.getattr_static(cls, "read_restart"), classmethod) or \
                got != ["path", "ctx"]:
            raise PluginError(
                f"writer '{cls.name}' from package '{package}': read_restart must be a "
                "classmethod read_restart(cls, path, ctx) (siku_core.interfaces.Writer)")
    if kind == "contact_law":
        from .contact_law import check_contact_law  # imported by .interfaces, after it

        check_contact_law(cls, package)



@functools.lru_cache(maxsize=1)
def _top_map() -> dict[str, list[str]]:
    """Top-level import names to the distributions providing them
    (``importlib.metadata.packages_distributions``), read once per process: scanning every
    installed distribution's file list takes about 0.3 s. A refreshed registry reads it again."""
    try:
        return md.packages_distributions()
    except Exception:  # pragma: no cover - metadata quirks
        return {}


def own_distribution() -> str | None:
    """The name of the distribution that installed ``siku_core`` (``"siku"``), ``None`` when
    it runs from a source tree without installed metadata."""
    dists = _top_map().get(__name__.split(".")[0], [])
    return dists[0] if dists else None


def _own_modules() -> frozenset[str]:
    """Top-level import names of siku's own distribution: ``siku_core`` and the packages its
    entry points name (read from the installed metadata, never listed here)."""
    top = __name__.split(".")[0]
    names = {top}
    dist = own_distribution()
    if dist is not None:
        for ep in md.distribution(dist).entry_points:
            if ep.group == "siku":
                names.add(ep.value.split(".")[0].split(":")[0])
    return frozenset(names)


def package_of(cls: type) -> tuple[str, str]:
    """The distribution providing ``cls`` and its version (``("siku", version)`` for siku's
    own packages; for a module of a package that is not installed, its top-level name and
    ``__version__``)."""
    return _dist_of(cls.__module__)


def _dist_of(module_name: str, top_map: dict[str, list[str]] | None = None) -> tuple[str, str]:
    top = module_name.split(".")[0]
    try:
        dists = (_top_map() if top_map is None else top_map).get(top, [])
        if dists:
            return dists[0], md.version(dists[0])
    except Exception:  # pragma: no cover - metadata quirks
        pass
    if top in _own_modules():  # siku itself, e.g. run from a source tree without metadata
        from .versions import __version__

        return "siku", __version__
    # not installed (registered with register_module): the package's own __version__, if any
    return top, str(getattr(sys.modules.get(top), "__version__", "unknown"))


def canonical_dist(dist: str) -> str:
    return dist.strip().lower().replace("_", "-").replace(".", "-")


def skipped_distributions() -> frozenset[str]:
    """Distributions named in ``SIKU_SKIP_PLUGINS`` (comma-separated; siku's own is never
    skipped)."""
    names = os.environ.get("SIKU_SKIP_PLUGINS", "").split(",")
    return frozenset(canonical_dist(n) for n in names if n.strip())


def make_plugin_manager(autoload: bool | None = None, extra: tuple[Any, ...] = ()) -> tuple[
    pluggy.PluginManager, Registry
]:
    """Build a plugin manager with the built-ins, entry-point plugins and ``extra`` modules."""
    pm = pluggy.PluginManager("siku")
    pm.add_hookspecs(SikuHookspecs)
    reg = Registry()
    if autoload is None:
        autoload = os.environ.get("SIKU_DISABLE_PLUGIN_AUTOLOAD", "") not in ("1", "true", "yes")
    own = own_distribution()
    skip = skipped_distributions()
    builtin = 0
    for ep in md.entry_points(group="siku"):
        dist = ep.dist.name if ep.dist else ep.value
        mine = own is not None and dist == own
        if not (mine or autoload) or (not mine and canonical_dist(dist) in skip):
            continue
        if pm.get_plugin(ep.value) is not None or pm.is_blocked(ep.value):
            continue  # the same module named twice (two copies of one distribution)
        try:
            mod = ep.load()
        except Exception as exc:
            if mine:  # siku's own module: a fault of this installation, never hidden
                raise PluginError(f"siku's own plugin module '{ep.value}' failed to load: "
                                  f"{type(exc).__name__}: {exc}") from exc
            reg.broken[dist] = f"{type(exc).__name__}: {exc}"  # must not break every run
            warnings.warn(
                f"siku plugin '{ep.name}' from package '{dist}' failed to load: {exc}",
                stacklevel=2,
            )
            continue
        pm.register(mod, name=ep.value)
        builtin += mine
    if not builtin:
        raise PluginError(
            "siku's built-in components are not registered: the package's entry points are "
            "missing (run from a source tree?); install it with pip install -e ."
        )
    for mod in extra:
        pm.register(mod)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin hook without a specification: {exc}") from None
    top_map = _top_map()
    strict_plugins = {id(m) for m in extra}
    for kind, hook in _REGISTER_HOOKS.items():
        impls = getattr(pm.hook, hook).get_hookimpls()
        for impl in impls:
            plugin_mod = getattr(impl.plugin, "__name__", impl.plugin_name)
            package, version = _dist_of(plugin_mod, top_map)
            reg.plugins[package] = version
            # siku's own components and explicitly registered modules: faults are errors
            strict = package == "siku" or id(impl.plugin) in strict_plugins
            for cls in impl.function() or []:
                reg.add(kind, cls, package, version, strict=strict)
    return pm, reg


_CACHE: dict[str, tuple[pluggy.PluginManager, Registry]] = {}
_EXTRA: list[Any] = []


def get_registry(refresh: bool = False) -> Registry:
    """The process-wide registry (built on first use)."""
    if refresh or "default" not in _CACHE:
        if refresh:
            _top_map.cache_clear()  # distributions installed since the last build
        _CACHE["default"] = make_plugin_manager(extra=tuple(_EXTRA))
    return _CACHE["default"][1]


def get_plugin_manager(refresh: bool = False) -> pluggy.PluginManager:
    """The process-wide plugin manager (built on first use)."""
    get_registry(refresh)
    return _CACHE["default"][0]


def register_module(module: Any) -> Registry:
    """Register a plugin module in the process-wide manager (tests, notebooks).

    Equivalent to installing a package whose ``siku`` entry point names ``module``.
    """
    added = module not in _EXTRA
    if added:
        _EXTRA.append(module)
    try:
        return get_registry(refresh=True)
    except Exception:
        if added:  # a module that fails to register must not break later runs
            _EXTRA.remove(module)
            get_registry(refresh=True)
        raise


def unregister_module(module: Any) -> Registry:
    """Undo :func:`register_module`."""
    if module in _EXTRA:
        _EXTRA.remove(module)
    return get_registry(refresh=True)
