"""siku: discrete-element sea-ice model on a rotating sphere (core engine).

``import siku_core`` loads the engine only: no plugins, no h5py, netCDF4 or xarray. It sets
``OMP_WAIT_POLICY=PASSIVE`` unless the user chose how OpenMP threads wait
(:mod:`siku_core.thread_env`).
"""
from __future__ import annotations

__version__ = "0.1.0"

from .thread_env import set_quiet_defaults  # noqa: E402

set_quiet_defaults()  # before numba starts a thread: idle threads sleep (siku_core.thread_env)

from .errors import (  # noqa: E402
    DataError,
    GeometryError,
    NonFiniteError,
    PluginError,
    SceneError,
    SikuError,
    StabilityError,
)
from .params import Param  # noqa: E402
from .plugins import hookimpl, hookspec  # noqa: E402

__all__ = [
    "__version__", "hookimpl", "hookspec", "Param", "Simulation", "load_scene",
    "SikuError", "SceneError", "PluginError", "GeometryError", "StabilityError",
    "NonFiniteError", "DataError",
]


def __getattr__(name: str):
    if name == "Simulation":
        from .simulation import Simulation

        return Simulation
    if name == "load_scene":
        from .scene import load_scene

        return load_scene
    raise AttributeError(name)
