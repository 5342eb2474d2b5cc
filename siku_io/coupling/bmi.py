"""Basic Model Interface (BMI 2.0, ``bmipy``) for a siku run: another model drives the ice.

``initialize(scene.toml)`` builds the run of a scene that has ``[coupling.grid]`` (the exchange
grid) and ``[[forcing]] source = "exchange"`` (the forces of the fields another model sets); see
``siku_forcing.gridded.exchange`` for what flows each way. Time is in seconds from the scene's
start;
one ``update`` is one time step. Every variable lives on grid 0, the exchange grid: a
``uniform_rectilinear`` grid of ``(ny, nx)`` nodes at the cell centres (spacing and origin in
degrees on a ``lonlat`` grid, projected metres on a ``polar_stereographic`` one), values flattened
row by row (``y`` slowest), vectors along the grid's x and y axes.

A scene whose ``waves`` forcing takes the ``spectral`` field has two more grids and the
variables of ``siku_io.coupling.waves``: the incident spectrum as an input, the ice's attenuation
per cell as an output.

The scene's ``[output]`` file is written only with ``[coupling] write_output = true``.

Example::

    from siku_io.coupling.bmi import SikuBmi

    ice = SikuBmi()
    ice.initialize("coupled.toml")
    ice.set_value("sea_water_surface__elevation", eta)     # from the wave model
    ice.update_until(ice.get_current_time() + 10.0)
    ice.get_value("sea_ice__area_fraction", conc)          # to the wave model
    ice.finalize()
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from bmipy import Bmi

from siku_core.errors import InputError

from siku_forcing.gridded.exchange import INPUT_BOUNDS
from siku_forcing.gridded.exchange import INPUTS as EXCHANGE_INPUTS

#: BMI standard name -> the ``exchange`` forcing source's input field (its units and meaning
#: are those of ``siku_forcing.gridded.exchange.INPUTS``, the one table of the exchange inputs)
_INPUT_FIELDS = {
    "sea_water_surface__elevation": "eta",
    "sea_water_flowing__x_component_of_velocity": "water_u",
    "sea_water_flowing__y_component_of_velocity": "water_v",
    "sea_ice_bottom_surface__x_component_of_stress": "tau_x",
    "sea_ice_bottom_surface__y_component_of_stress": "tau_y",
    "atmosphere_bottom_air_flow__x_component_of_velocity": "wind_u",
    "atmosphere_bottom_air_flow__y_component_of_velocity": "wind_v",
    "sea_ice_bottom_surface__dynamic_pressure": "pressure",
}
#: name -> (exchange key, units, "in"/"out", description). Input keys are fields of the
#: ``exchange`` forcing source; output keys those of ``siku_forcing.gridded.exchange.ice_fields``
#: (plus the per-cell force the ice received).
VARIABLES: dict[str, tuple[str, str, str, str]] = {
    **{name: (key, EXCHANGE_INPUTS[key][0], "in", EXCHANGE_INPUTS[key][1])
       for name, key in _INPUT_FIELDS.items()},
    "sea_ice__area_fraction": ("area_fraction", "1", "out", "ice area over cell area"),
    "sea_ice__volume": ("volume", "m3", "out", "ice volume in the cell"),
    "sea_ice_top_surface__elevation": ("top", "m", "out", "highest ice top in the cell"),
    "sea_ice_bottom_surface__elevation": ("bottom", "m", "out", "lowest ice bottom in the cell"),
    "sea_ice__x_component_of_velocity": ("u", "m s-1", "out", "mass-weighted ice velocity, x"),
    "sea_ice__y_component_of_velocity": ("v", "m s-1", "out", "mass-weighted ice velocity, y"),
    "sea_ice__x_component_of_acceleration": (
        "ax", "m s-2", "out", "mass-weighted ice acceleration over the last update, x"),
    "sea_ice__y_component_of_acceleration": (
        "ay", "m s-2", "out", "mass-weighted ice acceleration over the last update, y"),
    "sea_ice__x_component_of_coupling_force": (
        "force_x", "N", "out", ("force of the exchange fields on the ice in the cell, x "
        "(mean over the last update)")),
    "sea_ice__y_component_of_coupling_force": (
        "force_y", "N", "out", ("force of the exchange fields on the ice in the cell, y "
        "(mean over the last update)")),
}
INPUT_NAMES = tuple(k for k, v in VARIABLES.items() if v[2] == "in")
OUTPUT_NAMES = tuple(k for k, v in VARIABLES.items() if v[2] == "out")


class SikuBmi(Bmi):
    """A siku run behind the Basic Model Interface (module docstring)."""

    def __init__(self) -> None:
        self.sim = None
        self._state = "created"  # "initialized", then "finalized"
        self._out: dict[str, np.ndarray] = {}
        self._out_step = -1
        self.waves = None  # the spectral wave field's coupling (siku_io.coupling.waves)

    def __getattr__(self, name: str):
        # the run's attributes (grid, exchange...) exist only between initialize and finalize
        if name in ("grid", "exchange", "_before", "_interval"):
            self._run()
        raise AttributeError(name)

    def _run(self):
        """The running simulation; a :class:`RuntimeError` naming the state otherwise."""
        if self.sim is None:
            if self.__dict__.get("_state") == "finalized":
                raise RuntimeError("SikuBmi: the model is finalized; create a new SikuBmi and "
                                   "call initialize(scene.toml) to run again")
            raise RuntimeError("SikuBmi: the model is not initialized; call "
                               "initialize(scene.toml) first")
        return self.sim

    # ------------------------------------------------------------------ control
    def initialize(self, config_file: str | None = None) -> None:
        from siku_core import SceneError, load_scene
        from siku_core.run.simulation import Simulation
        from siku_forcing.gridded.exchange import Exchange, coupling_grid, grid_velocity

        if self.sim is not None:
            raise RuntimeError("SikuBmi: the model is already initialized; call finalize() "
                               "first, or create another SikuBmi")
        if not config_file:
            raise SceneError("SikuBmi.initialize needs a scene file (TOML with [coupling.grid])")
        scene = load_scene(Path(config_file))
        self.grid = coupling_grid(scene)
        write = bool((scene.cfg.coupling or {}).get("write_output", False))
        self.sim = Simulation(scene, out=None if write else False, progress=False)
        ex = [f for f in self.sim.forcing if isinstance(f, Exchange)]
        if not ex:
            raise SceneError(f"{scene.label}: a coupled run needs [[forcing]] source = "
                             "\"exchange\" to receive the other model's fields")
        self.exchange: Exchange = ex[0]
        for proc in self.sim.processes:     # a floating process takes its wave from the grid
            proc.couple_exchange(self.exchange)
        from .waves import WaveCoupling, spectral_field

        field = spectral_field(self.sim)
        self.waves = WaveCoupling(field) if field is not None else None
        self.sim.open_outputs()
        self._before = grid_velocity(self.sim, self.grid)
        self._interval = 0.0
        self._out = {}
        self._out_step = -1
        self._state = "initialized"

    def update(self) -> None:
        """One time step; a :class:`RuntimeError` at the end time."""
        sim = self._run()
        if sim.step_index >= sim.n_steps:
            raise RuntimeError(f"SikuBmi.update: the run is at its end time "
                               f"({self.get_end_time():g} s); it cannot step further")
        self._advance(1)

    def update_until(self, time: float) -> None:
        """Step until ``time`` [s]: the last step that does not pass it (a time between two
        steps stops at the earlier one; a time past the end stops at the end). A time before
        the current one is a :class:`ValueError`."""
        sim = self._run()
        try:
            t = float(time)
        except (TypeError, ValueError):
            raise InputError(f"SikuBmi.update_until: time {time!r} is not a number of "
                             "seconds") from None
        if not np.isfinite(t) or t < sim.time - 1e-9 * max(1.0, abs(sim.time)):
            raise InputError(f"SikuBmi.update_until({time!r}): the model is at t = "
                             f"{sim.time:g} s and runs forward only; give a time >= "
                             f"{sim.time:g} s")
        n = int(np.floor((t - sim.time) / sim.dt + 1e-9))
        self._advance(max(0, min(n, sim.n_steps - sim.step_index)))

    def _advance(self, n: int) -> None:
        from siku_forcing.gridded.exchange import grid_velocity

        sim = self.sim
        if n <= 0:
            return
        self.exchange.refresh()
        before = grid_velocity(sim, self.grid)
        t0 = sim.time
        sim.advance(n)
        self._before, self._interval = before, sim.time - t0
        self._out_step = -1

    def finalize(self) -> None:
        if self.sim is not None:
            self.sim.close()
            self.sim = None
            self.waves = None
            self._state = "finalized"

    # ------------------------------------------------------------------ info
    def get_component_name(self) -> str:
        return "siku"

    def _wave_names(self, way: str) -> tuple[str, ...]:
        from .waves import WAVE_VARIABLES as WAVES

        if self.waves is None:
            return ()
        return tuple(k for k, v in WAVES.items() if v[2] == way)

    def get_input_item_count(self) -> int:
        return len(self.get_input_var_names())

    def get_output_item_count(self) -> int:
        return len(self.get_output_var_names())

    # the BMI 1 names of the counts, which some tools still call
    get_input_var_name_count = get_input_item_count
    get_output_var_name_count = get_output_item_count

    def get_input_var_names(self) -> tuple[str, ...]:
        return INPUT_NAMES + self._wave_names("in")

    def get_output_var_names(self) -> tuple[str, ...]:
        return OUTPUT_NAMES + self._wave_names("out")

    # ------------------------------------------------------------------ variables
    def _var(self, name: str):
        from .waves import WAVE_VARIABLES as WAVES

        if name in VARIABLES:
            return VARIABLES[name]
        if self.waves is not None and name in WAVES:
            return WAVES[name][:4]
        known = list(VARIABLES) + (list(WAVES) if self.waves is not None else [])
        raise KeyError(f"unknown variable {name!r}; siku has: " + ", ".join(known)
                       + ("" if self.waves is not None else " (and, in a scene with the "
                          "spectral wave field, " + ", ".join(WAVES) + ")"))

    def get_var_grid(self, name: str) -> int:
        from .waves import WAVE_VARIABLES as WAVES

        self._var(name)
        return WAVES[name][4] if name in WAVES else 0

    def get_var_type(self, name: str) -> str:
        self._var(name)
        return "float64"

    def get_var_units(self, name: str) -> str:
        return self._var(name)[1]

    def get_var_itemsize(self, name: str) -> int:
        self._var(name)
        return 8

    def get_var_nbytes(self, name: str) -> int:
        return 8 * self.get_grid_size(self.get_var_grid(name))

    def get_var_location(self, name: str) -> str:
        self._var(name)
        return "node"

    # ------------------------------------------------------------------ time
    def get_current_time(self) -> float:
        return float(self._run().time)

    def get_start_time(self) -> float:
        return 0.0

    def get_end_time(self) -> float:
        sim = self._run()
        return float(sim.n_steps * sim.dt)

    def get_time_units(self) -> str:
        return "s"

    def get_time_step(self) -> float:
        return float(self._run().dt)

    # ------------------------------------------------------------------ values
    def _outputs(self) -> dict[str, np.ndarray]:
        from siku_forcing.gridded.exchange import ice_fields

        sim = self._run()
        if self._out_step != sim.step_index:
            ex = self.exchange
            f = ice_fields(sim, self.grid, ex.fields["eta"], float(ex.p["rho"]), self._before,
                           self._interval)
            fx, fy = ex.mean_cell_force()
            f["force_x"], f["force_y"] = fx, fy
            self._out = {k: np.ascontiguousarray(v.ravel()) for k, v in f.items()}
            self._out_step = sim.step_index
        return self._out

    def get_value_ptr(self, name: str) -> np.ndarray:
        """The variable's array: for inputs the array the forces read (writing into it sets the
        input); for outputs the values at the current time (recomputed after an update), as a
        read-only array."""
        key, _, way, _ = self._var(name)
        self._run()
        if way == "in":
            return self.waves.input(key) if self.get_var_grid(name) else \
                self.exchange.fields[key].reshape(-1)
        out = (self.waves.output(key) if self.get_var_grid(name) else self._outputs()[key]).view()
        out.flags.writeable = False  # an output: what siku computed, not to be written
        return out

    def get_value(self, name: str, dest: np.ndarray) -> np.ndarray:
        src = self.get_value_ptr(name)
        self._dest(name, dest, src.size)[:] = src
        return dest

    def get_value_at_indices(self, name: str, dest: np.ndarray, inds: np.ndarray) -> np.ndarray:
        src = self.get_value_ptr(name)
        inds = self._indices(name, inds, src.size)
        self._dest(name, dest, inds.size)[:] = src[inds]
        return dest

    @staticmethod
    def _dest(name: str, dest, n: int) -> np.ndarray:
        """``dest`` as a flat view: a writable float64 array of ``n`` values, or a
        :class:`ValueError` naming the variable, the expected shape and dtype."""
        if (not isinstance(dest, np.ndarray) or dest.dtype != np.float64 or dest.size != n
                or not dest.flags.writeable):
            got = (f"{dest.dtype} array of shape {dest.shape}" if isinstance(dest, np.ndarray)
                   else type(dest).__name__)
            raise InputError(f"{name}: the destination must be a writable float64 array of "
                             f"shape ({n},); got a {got}")
        return dest.reshape(-1)

    @staticmethod
    def _indices(name: str, inds, n: int) -> np.ndarray:
        """Indices as int64: integers in ``[0, n)``, else a :class:`ValueError`."""
        a = np.asarray(inds)
        if a.dtype.kind not in "iu" or a.ndim > 1:
            raise InputError(f"{name}: indices must be a 1-D integer array (of shape (k,), "
                             f"dtype int); got {a.dtype} of shape {a.shape}")
        if a.size and (a.min() < 0 or a.max() >= n):  # (before any cast can wrap them)
            raise InputError(f"{name}: indices must lie in [0, {n - 1}] (a grid of {n} "
                             f"nodes); got {int(a.min())} to {int(a.max())}")
        return a.astype(np.int64).reshape(-1)

    @staticmethod
    def _values(name: str, src, n: int | None) -> np.ndarray:
        """Values to set as float64: real numbers (``n`` of them when given), all finite."""
        a = np.asarray(src)
        if a.dtype.kind not in "iuf":
            raise InputError(f"{name}: values must be real numbers (a float64 array of shape "
                             f"({n if n is not None else 'k'},)); got {a.dtype}")
        a = a.astype(np.float64).reshape(-1)
        if n is not None and a.size != n:
            raise InputError(f"{name}: {a.size} values for a grid of {n} nodes (a float64 "
                             f"array of shape ({n},))")
        if not np.isfinite(a).all():
            raise InputError(f"{name}: values must be finite")
        return a

    def _input(self, name: str) -> np.ndarray:
        key, _, way, _ = self._var(name)
        self._run()
        if way != "in":
            raise InputError(f"{name} is an output of siku; its inputs are: "
                             + ", ".join(self.get_input_var_names()))
        if self.get_var_grid(name):
            return self.waves.input(key)
        return self.exchange.fields[key].reshape(-1)

    def _set(self, name: str, a: np.ndarray, where, values: np.ndarray) -> None:
        if self.get_var_grid(name):
            self.waves.set_input(name, values, where)  # refused before anything is written
            a[where] = values
            return
        key = self._var(name)[0]
        top = INPUT_BOUNDS.get(key, np.inf)
        if values.size and np.abs(values).max() > top:
            j = int(np.argmax(np.abs(values)))
            raise InputError(f"{name}: {values[j]:g} {self.get_var_units(name)} is beyond what "
                             f"the model can mean (at most {top:g} in magnitude)")
        a[where] = values
        self.exchange.given.add(self._var(name)[0])
        self.exchange.inputs_changed()

    def set_value(self, name: str, src: np.ndarray) -> None:
        a = self._input(name)
        self._set(name, a, slice(None), self._values(name, src, a.size))

    def set_value_at_indices(self, name: str, inds: np.ndarray, src: np.ndarray) -> None:
        a = self._input(name)
        inds = self._indices(name, inds, a.size)
        self._set(name, a, inds, self._values(name, src, inds.size))

    # ------------------------------------------------------------------ grid
    def _check_grid(self, grid: int) -> None:
        if grid == 0 or (grid in (1, 2) and self.waves is not None):
            return
        raise KeyError(f"unknown grid {grid}; siku has grid 0 (the exchange grid)" + (
            ", 1 (the spectral wave grid) and 2 (the wave components)" if self.waves is not None
            else ""))

    def _shape(self, grid: int) -> tuple[int, ...]:
        self._check_grid(grid)
        return tuple(self.grid.shape) if grid == 0 else self.waves.shape(grid)

    def get_grid_rank(self, grid: int) -> int:
        return len(self._shape(grid))

    def get_grid_size(self, grid: int) -> int:
        return int(np.prod(self._shape(grid)))

    def get_grid_type(self, grid: int) -> str:
        self._check_grid(grid)
        return "uniform_rectilinear"

    def get_grid_shape(self, grid: int, shape: np.ndarray) -> np.ndarray:
        shape[:] = self._shape(grid)
        return shape

    def get_grid_spacing(self, grid: int, spacing: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        g = self.grid
        spacing[:] = (g.y_edges[1] - g.y_edges[0], g.x_edges[1] - g.x_edges[0]) if grid == 0 \
            else self.waves.spacing(grid)
        return spacing

    def get_grid_origin(self, grid: int, origin: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        origin[:] = (self.grid.y[0], self.grid.x[0]) if grid == 0 else self.waves.origin(grid)
        return origin

    def get_grid_x(self, grid: int, x: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        x[:] = self.grid.x if grid == 0 else self.waves.x(grid)
        return x

    def get_grid_y(self, grid: int, y: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        y[:] = self.grid.y if grid == 0 else self.waves.y(grid)
        return y

    def get_grid_z(self, grid: int, z: np.ndarray) -> np.ndarray:
        raise NotImplementedError("the exchange grid is two-dimensional")

    def get_grid_node_count(self, grid: int) -> int:
        return self.get_grid_size(grid)

    def get_grid_edge_count(self, grid: int) -> int:
        shape = self._shape(grid)
        if len(shape) == 1:
            return shape[0] - 1
        ny, nx = shape
        return ny * (nx - 1) + nx * (ny - 1)

    def get_grid_face_count(self, grid: int) -> int:
        shape = self._shape(grid)
        if len(shape) == 1:
            return 0
        ny, nx = shape
        return (ny - 1) * (nx - 1)

    def _unstructured(self, *args: Any) -> np.ndarray:
        raise NotImplementedError("the exchange grid is uniform rectilinear: no connectivity")

    get_grid_edge_nodes = _unstructured
    get_grid_face_edges = _unstructured
    get_grid_face_nodes = _unstructured
    get_grid_nodes_per_face = _unstructured
