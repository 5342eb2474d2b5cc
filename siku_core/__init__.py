"""siku: discrete-element sea-ice model on a rotating sphere (core engine).

``import siku_core`` loads the engine only: no plugins, no h5py, netCDF4 or xarray.
"""
from __future__ import annotations

from .errors import (  # noqa: E402
    DataError,
    GeometryError,
    InputError,
    NonFiniteError,
    PluginError,
    SceneError,
    SikuError,
    StabilityError,
)
from .params import Param  # noqa: E402
from .plugins import hookimpl, hookspec  # noqa: E402
from .versions import PLUGIN_API_VERSION, __version__  # noqa: E402
from .numba_cache import install as _install_numba_cache  # noqa: E402

# numba caches siku's compiled functions by the hash of siku's sources (siku_core.numba_cache),
# from the first one on: a fresh clone of sources compiled before reads them compiled
_install_numba_cache()

__all__ = [
    "__version__", "PLUGIN_API_VERSION", "hookimpl", "hookspec", "Param", "Simulation",
    "load_scene",
    "SikuError", "SceneError", "PluginError", "GeometryError", "StabilityError",
    "NonFiniteError", "DataError", "InputError",
]


def __getattr__(name: str):
    if name == "Simulation":
        from .run.simulation import Simulation

        return Simulation
    if name == "load_scene":
        from .scene.scene_file import load_scene

        return load_scene
    raise AttributeError(name)
