"""Basic Model Interface (BMI 2.0, ``bmipy``) for a siku run: another model drives the ice.

``initialize(scene.toml)`` builds the run of a scene that has ``[coupling.grid]`` (the exchange
grid) and ``[[forcing]] source = "exchange"`` (the forces of the fields another model sets); see
``siku_io.coupling.exchange`` for what flows each way. Time is in seconds from the scene's start;
one ``update`` is one time step. Every variable lives on grid 0, the exchange grid: a
``uniform_rectilinear`` grid of ``(ny, nx)`` nodes at the cell centres (spacing and origin in
degrees on a ``lonlat`` grid, projected metres on a ``polar_stereographic`` one), values flattened
row by row (``y`` slowest), vectors along the grid's x and y axes.

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

from .exchange import INPUTS as EXCHANGE_INPUTS

#: BMI standard name -> the ``exchange`` forcing source's input field (its units and meaning
#: are those of ``siku_io.coupling.exchange.INPUTS``, the one table of the exchange inputs)
_INPUT_FIELDS = {
    "sea_water_surface__elevation": "eta",
    "sea_water_flowing__x_component_of_velocity": "water_u",
    "sea_water_flowing__y_component_of_velocity": "water_v",
    "sea_ice_bottom_surface__x_component_of_stress": "tau_x",
    "sea_ice_bottom_surface__y_component_of_stress": "tau_y",
    "atmosphere_bottom_air_flow__x_component_of_velocity": "wind_u",
    "atmosphere_bottom_air_flow__y_component_of_velocity": "wind_v",
}
#: name -> (exchange key, units, "in"/"out", description). Input keys are fields of the
#: ``exchange`` forcing source; output keys those of ``siku_io.coupling.exchange.ice_fields``
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
        self._out: dict[str, np.ndarray] = {}
        self._out_step = -1

    # ------------------------------------------------------------------ control
    def initialize(self, config_file: str | None = None) -> None:
        from siku_core import SceneError, load_scene
        from siku_core.simulation import Simulation
        from siku_io.coupling.exchange import Exchange, coupling_grid, grid_velocity

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
        self.sim.open_outputs()
        self._before = grid_velocity(self.sim, self.grid)
        self._interval = 0.0
        self._out = {}
        self._out_step = -1

    def update(self) -> None:
        self._advance(1)

    def update_until(self, time: float) -> None:
        """Step until ``time`` [s]: the last step that does not pass it (a time between two
        steps stops at the earlier one)."""
        sim = self.sim
        n = int(np.floor((float(time) - sim.time) / sim.dt + 1e-9))
        self._advance(max(0, min(n, sim.n_steps - sim.step_index)))

    def _advance(self, n: int) -> None:
        from siku_io.coupling.exchange import grid_velocity

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

    # ------------------------------------------------------------------ info
    def get_component_name(self) -> str:
        return "siku"

    def get_input_item_count(self) -> int:
        return len(INPUT_NAMES)

    def get_output_item_count(self) -> int:
        return len(OUTPUT_NAMES)

    # the BMI 1 names of the counts, which some tools still call
    get_input_var_name_count = get_input_item_count
    get_output_var_name_count = get_output_item_count

    def get_input_var_names(self) -> tuple[str, ...]:
        return INPUT_NAMES

    def get_output_var_names(self) -> tuple[str, ...]:
        return OUTPUT_NAMES

    # ------------------------------------------------------------------ variables
    def _var(self, name: str):
        try:
            return VARIABLES[name]
        except KeyError:
            raise KeyError(f"unknown variable {name!r}; siku has: "
                           + ", ".join(VARIABLES)) from None

    def get_var_grid(self, name: str) -> int:
        self._var(name)
        return 0

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
        return float(self.sim.time)

    def get_start_time(self) -> float:
        return 0.0

    def get_end_time(self) -> float:
        return float(self.sim.n_steps * self.sim.dt)

    def get_time_units(self) -> str:
        return "s"

    def get_time_step(self) -> float:
        return float(self.sim.dt)

    # ------------------------------------------------------------------ values
    def _outputs(self) -> dict[str, np.ndarray]:
        from siku_io.coupling.exchange import ice_fields

        sim = self.sim
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
        input); for outputs the values at the current time (recomputed after an update)."""
        key, _, way, _ = self._var(name)
        if way == "in":
            return self.exchange.fields[key].reshape(-1)
        return self._outputs()[key]

    def get_value(self, name: str, dest: np.ndarray) -> np.ndarray:
        dest[:] = self.get_value_ptr(name)
        return dest

    def get_value_at_indices(self, name: str, dest: np.ndarray, inds: np.ndarray) -> np.ndarray:
        dest[:] = self.get_value_ptr(name)[np.asarray(inds, dtype=np.int64)]
        return dest

    def _input(self, name: str) -> np.ndarray:
        key, _, way, _ = self._var(name)
        if way != "in":
            raise ValueError(f"{name} is an output of siku; its inputs are: "
                             + ", ".join(INPUT_NAMES))
        return self.exchange.fields[key].reshape(-1)

    def set_value(self, name: str, src: np.ndarray) -> None:
        a = self._input(name)
        src = np.asarray(src, dtype=float).reshape(-1)
        if src.shape != a.shape:
            raise ValueError(f"{name}: {src.size} values for a grid of {a.size} nodes")
        if not np.isfinite(src).all():
            raise ValueError(f"{name}: values must be finite")
        a[:] = src
        self.exchange.inputs_changed()

    def set_value_at_indices(self, name: str, inds: np.ndarray, src: np.ndarray) -> None:
        a = self._input(name)
        src = np.asarray(src, dtype=float).reshape(-1)
        if not np.isfinite(src).all():
            raise ValueError(f"{name}: values must be finite")
        a[np.asarray(inds, dtype=np.int64)] = src
        self.exchange.inputs_changed()

    # ------------------------------------------------------------------ grid
    def _check_grid(self, grid: int) -> None:
        if grid != 0:
            raise KeyError(f"unknown grid {grid}; siku has grid 0 (the exchange grid)")

    def get_grid_rank(self, grid: int) -> int:
        self._check_grid(grid)
        return 2

    def get_grid_size(self, grid: int) -> int:
        self._check_grid(grid)
        ny, nx = self.grid.shape
        return ny * nx

    def get_grid_type(self, grid: int) -> str:
        self._check_grid(grid)
        return "uniform_rectilinear"

    def get_grid_shape(self, grid: int, shape: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        shape[:] = self.grid.shape
        return shape

    def get_grid_spacing(self, grid: int, spacing: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        g = self.grid
        spacing[:] = (g.y_edges[1] - g.y_edges[0], g.x_edges[1] - g.x_edges[0])
        return spacing

    def get_grid_origin(self, grid: int, origin: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        origin[:] = (self.grid.y[0], self.grid.x[0])
        return origin

    def get_grid_x(self, grid: int, x: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        x[:] = self.grid.x
        return x

    def get_grid_y(self, grid: int, y: np.ndarray) -> np.ndarray:
        self._check_grid(grid)
        y[:] = self.grid.y
        return y

    def get_grid_z(self, grid: int, z: np.ndarray) -> np.ndarray:
        raise NotImplementedError("the exchange grid is two-dimensional")

    def get_grid_node_count(self, grid: int) -> int:
        return self.get_grid_size(grid)

    def get_grid_edge_count(self, grid: int) -> int:
        self._check_grid(grid)
        ny, nx = self.grid.shape
        return ny * (nx - 1) + nx * (ny - 1)

    def get_grid_face_count(self, grid: int) -> int:
        self._check_grid(grid)
        ny, nx = self.grid.shape
        return (ny - 1) * (nx - 1)

    def _unstructured(self, *args: Any) -> np.ndarray:
        raise NotImplementedError("the exchange grid is uniform rectilinear: no connectivity")

    get_grid_edge_nodes = _unstructured
    get_grid_face_edges = _unstructured
    get_grid_face_nodes = _unstructured
    get_grid_nodes_per_face = _unstructured
