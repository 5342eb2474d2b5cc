"""siku's version and the version of its plugin interface.

* :data:`__version__`: the release, read from the installed distribution's metadata (the one
  source is ``version`` in ``pyproject.toml``; after changing it, ``pip install -e .`` again).
  Semantic versioning: before 1.0 a minor release (0.2 -> 0.3) may change the public surface,
  with the deprecation aliases of :mod:`siku_core.deprecation`; a patch release does not.
* :data:`PLUGIN_API_VERSION`: ``"major.minor"`` of the interface plugins are written against
  (the public surface of ``docs/reference/api.md``). A minor step adds to it, a major step breaks
  it. It is recorded in every output file (``siku_plugin_api``). A component may declare
  ``requires_api`` (``"1"``, ``"1.x"``: any 1.*; ``"1.2"``: 1.2 or a later 1.*); one this siku
  cannot serve is refused when it registers (:func:`api_mismatch`, called by
  :func:`siku_core.plugins.check_component`).
"""
from __future__ import annotations

import importlib.metadata as md
import re
from typing import Any

try:
    __version__ = md.version("siku")
except md.PackageNotFoundError:  # pragma: no cover - a source tree never installed
    __version__ = "0+unknown"

#: the plugin interface this siku provides, "major.minor"
PLUGIN_API_VERSION = "1.1"

_REQUIRES = re.compile(r"^\s*(\d+)(?:\.(x|\*|\d+))?\s*$")


def api_mismatch(requires: Any, provided: str = PLUGIN_API_VERSION) -> str:
    """Why a component declaring ``requires_api = requires`` cannot run with the plugin API
    ``provided``; ``""`` when it can. ``requires``: ``"M"`` or ``"M.x"`` (any minor of major
    ``M``), ``"M.m"`` (major ``M``, minor ``m`` or later)."""
    got = _REQUIRES.match(requires) if isinstance(requires, str) else None
    if got is None:
        return (f"requires_api = {requires!r} is not a plugin API version; write 'M.x' "
                "(any minor of major M) or 'M.m' (M.m or a later M.*), e.g. '1.x'")
    major, minor = int(got.group(1)), got.group(2)
    have_major, have_minor = (int(p) for p in provided.split("."))
    if major != have_major:
        return (f"it requires plugin API {requires.strip()}, this siku provides "
                f"{provided} (another major version)")
    if minor is not None and minor.isdigit() and int(minor) > have_minor:
        return (f"it requires plugin API {requires.strip()}, this siku provides "
                f"{provided} (an older minor version; upgrade siku)")
    return ""
