"""Hook specifications, the plugin manager and the component registries.

Every component, the built-in ones included, enters through the same ``pluggy`` hooks. Built-in
modules are registered by name (like pytest's default plugins); third-party packages declare

.. code-block:: toml

    [project.entry-points.siku]
    my_plugin = "my_package.siku_plugin"

and implement hooks with :data:`siku_core.hookimpl`. ``SIKU_DISABLE_PLUGIN_AUTOLOAD=1`` skips
entry-point loading. A broken third-party plugin becomes a warning naming its package, and an
error only when a scene asks for a name it would have provided.
"""
from __future__ import annotations

import importlib
import importlib.metadata as md
import inspect
import os
import sys
import warnings
from dataclasses import dataclass, field
from typing import Any

import pluggy

from .errors import PluginError
from .interfaces import KINDS, Component

hookspec = pluggy.HookspecMarker("siku")
hookimpl = pluggy.HookimplMarker("siku")

#: built-in plugin modules, imported lazily (never by ``import siku_core``)
DEFAULT_PLUGINS: tuple[str, ...] = (
    "siku_plugins.integrators",
    "siku_plugins.broad_phases",
    "siku_plugins.contact_laws",
    "siku_forcing.fields",
    "siku_forcing.gridded",
    "siku_forcing.drag",
    "siku_io.hdf5",
    "siku_plugins.sources",
    "siku_plugins.floes",
    "siku_io.sources",
    "siku_io.commands",
    "siku_plugins.lab",
)


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
    def siku_register_commands(self, subparsers: Any) -> None:
        """Add ``siku`` subcommands: ``subparsers.add_parser(name, help=...)`` from argparse;
        set ``func`` (``parser.set_defaults(func=fn)``, ``fn(args) -> exit status``)."""

    @hookspec
    def siku_draw(self, path: Any, field: Any) -> list:
        """Draw the pictures of an output file after ``siku run`` (``[output] plots = true``),
        coloured by the per-element ``field`` (``None``: the default); return their paths."""

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
}


@dataclass
class Entry:
    """A registered component and where it came from."""

    cls: type[Component]
    package: str
    version: str


@dataclass
class Registry:
    """Components of every kind, by name."""

    entries: dict[str, dict[str, Entry]] = field(default_factory=lambda: {k: {} for k in KINDS})
    broken: dict[str, str] = field(default_factory=dict)  # package -> error text
    plugins: dict[str, str] = field(default_factory=dict)  # package -> version

    def add(self, kind: str, cls: type, package: str, version: str) -> None:
        _check_component(kind, cls, package)
        table = self.entries[kind]
        if cls.name in table and table[cls.name].cls is not cls:
            other = table[cls.name].package
            raise PluginError(
                f"duplicate {kind} name '{cls.name}': registered by package '{other}' "
                f"and by package '{package}'"
            )
        table[cls.name] = Entry(cls, package, version)

    def names(self, kind: str) -> list[str]:
        return sorted(self.entries[kind])

    def get(self, kind: str, name: str, where: str = "") -> type[Component]:
        """Look up a component by registered name or by ``package.module:Class`` path."""
        if ":" in name:
            return self._by_path(kind, name, where)
        try:
            return self.entries[kind][name].cls
        except KeyError:
            pass
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
        _check_component(kind, obj, mod_name)
        return obj

    def entry(self, kind: str, name: str) -> Entry | None:
        return self.entries[kind].get(name)


def _check_component(kind: str, cls: Any, package: str) -> None:
    """Check a component class against its kind's interface; errors name the problem."""
    base = KINDS[kind]
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise PluginError(
            f"package '{package}' registered {cls!r} as a {kind}, but it does not subclass "
            f"siku_core.interfaces.{base.__name__}"
        )
    if not cls.name or not isinstance(cls.name, str):
        raise PluginError(f"{kind} class {cls.__qualname__} from '{package}' has no 'name'")
    for meth, expected in base.required.items():
        fn = getattr(cls, meth, None)
        if fn is None or getattr(fn, "__isabstractmethod__", False):
            raise PluginError(
                f"{kind} '{cls.name}' from package '{package}' does not implement {meth}()"
            )
        got = [p for p in inspect.signature(fn).parameters if p != "self"]
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


#: the import packages of the siku distribution (a third-party "siku_tides" is not one of them)
_OWN_PACKAGES = frozenset({"siku_core", "siku_plugins", "siku_forcing", "siku_io"})


def _dist_of(module_name: str, top_map: dict[str, list[str]] | None = None) -> tuple[str, str]:
    top = module_name.split(".")[0]
    try:
        dists = (md.packages_distributions() if top_map is None else top_map).get(top, [])
        if dists:
            return dists[0], md.version(dists[0])
    except Exception:  # pragma: no cover - metadata quirks
        pass
    if top in _OWN_PACKAGES:  # siku itself, e.g. run from a source tree without metadata
        from . import __version__

        return "siku", __version__
    # not installed (registered with register_module): the package's own __version__, if any
    return top, str(getattr(sys.modules.get(top), "__version__", "unknown"))


def make_plugin_manager(autoload: bool | None = None, extra: tuple[Any, ...] = ()) -> tuple[
    pluggy.PluginManager, Registry
]:
    """Build a plugin manager with the built-ins, entry-point plugins and ``extra`` modules."""
    pm = pluggy.PluginManager("siku")
    pm.add_hookspecs(SikuHookspecs)
    reg = Registry()
    for name in DEFAULT_PLUGINS:
        pm.register(importlib.import_module(name), name=name)
    if autoload is None:
        autoload = os.environ.get("SIKU_DISABLE_PLUGIN_AUTOLOAD", "") not in ("1", "true", "yes")
    if autoload:
        for ep in md.entry_points(group="siku"):
            if pm.get_plugin(ep.name) is not None or pm.is_blocked(ep.name):
                continue
            dist = ep.dist.name if ep.dist else ep.value
            try:
                mod = ep.load()
            except Exception as exc:  # a broken plugin must not break every run
                reg.broken[dist] = f"{type(exc).__name__}: {exc}"
                warnings.warn(
                    f"siku plugin '{ep.name}' from package '{dist}' failed to load: {exc}",
                    stacklevel=2,
                )
                continue
            pm.register(mod, name=ep.name)
    for mod in extra:
        pm.register(mod)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin hook without a specification: {exc}") from None
    try:  # scanning every installed distribution is slow: once per build
        top_map = md.packages_distributions()
    except Exception:  # pragma: no cover - metadata quirks
        top_map = {}
    for kind, hook in _REGISTER_HOOKS.items():
        impls = getattr(pm.hook, hook).get_hookimpls()
        for impl in impls:
            plugin_mod = getattr(impl.plugin, "__name__", impl.plugin_name)
            package, version = _dist_of(plugin_mod, top_map)
            reg.plugins[package] = version
            for cls in impl.function() or []:
                reg.add(kind, cls, package, version)
    return pm, reg


_CACHE: dict[str, tuple[pluggy.PluginManager, Registry]] = {}
_EXTRA: list[Any] = []


def get_registry(refresh: bool = False) -> Registry:
    """The process-wide registry (built on first use)."""
    if refresh or "default" not in _CACHE:
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
