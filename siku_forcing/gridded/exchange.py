"""The exchange grid of a coupled run: what the ice gives a wave or ocean model per cell, and the
forces the cells' fields exert on the ice (forcing source ``exchange``).

A scene names the grid in ``[coupling.grid]`` (keys of
``siku_forcing.gridded.regular_grid.GridCfg``:
``lonlat`` or ``polar_stereographic``) and takes the fields with ``[[forcing]] source =
"exchange"``. Element ``e`` and cell ``c`` share the ice area ``S_ec = fraction_ec S_e`` and mass
``m_ec = fraction_ec m_e`` (``Grid.overlap``: exact polygon clipping). For every such pair the
cell's fields exert, in grid components,

* slope: ``-m_ec g grad eta_c`` (``grad eta`` by central differences of the cell elevations,
  one-sided at the edges, over true distances on the sphere);
* drag: ``S_ec rho_w C |u_c - U_e| (u_c - U_e)``, ``u_c`` the cell's water velocity, ``C`` as
  for waves (log layer, Orzech et al. eq. 6, unless given);
* stress: ``S_ec tau_c``, a force per area handed over by the other model;
* wind: ``S_ec rho_a C_a |U_a| U_a`` (report eq. 19, no turning), ``U_a`` the cell's wind.

An element gets the sum over its cells; a cell reports the sum over its elements (``force_x``,
``force_y`` [N]: on free elements, the mean over the steps since the last exchange of each
step's first force evaluation): the same pair forces summed two ways, so what the ice
receives and what the cells report agree to round-off, cell by cell. The overlap is recomputed
at every exchange (:meth:`Exchange.refresh`), from the positions then, and held until the next.

What the ice reports per cell (:func:`ice_fields`), at the current positions: area fraction,
volume [m³], the elevations of the top and bottom of the floating ice (freeboard ``h (1 -
rho_i/rho_w)`` above and draft ``h rho_i / rho_w`` below the cell's surface elevation; the
highest top and lowest bottom among the cell's elements, the surface elevation itself where there
is no ice), mass-weighted mean velocity and acceleration (zero where there is no ice).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numba import njit

from siku_core import DataError, Param, SceneError, hookimpl
from siku_core.geometry.quat import east_north_row
from siku_core.interfaces import ForcingSource
from siku_core.records import record_type
from siku_core.state import FREE
from siku_forcing.drag import drag_stability_limit, quadratic_drag
from siku_forcing.waves.wave_field import WATER_DRAG_PARAMS, drag_coefficient
from siku_forcing.gridded.regular_grid import Grid, GridCfg, cell_means, grid_error

#: per-cell input fields of the exchange source: name -> (units, meaning)
INPUTS: dict[str, tuple[str, str]] = {
    "eta": ("m", "sea surface elevation"),
    "water_u": ("m s-1", "surface water velocity along the grid's x axis"),
    "water_v": ("m s-1", "surface water velocity along the grid's y axis"),
    "tau_x": ("N m-2", "force per area on the ice along x"),
    "tau_y": ("N m-2", "force per area on the ice along y"),
    "wind_u": ("m s-1", "wind velocity (10 m) along x"),
    "wind_v": ("m s-1", "wind velocity (10 m) along y"),
    "pressure": ("Pa", "dynamic pressure on the ice bottom (in excess of the still-water "
                 "hydrostatic), for the floating process's wave load"),
}

#: the largest magnitude of each input a model can mean, in its units: a sea surface 100 m
#: from still water (the highest waves measured are 30 m, tides 16 m), the dynamic pressure of
#: that head (rho g 100 m), currents of 10 m/s (the fastest tidal races run 8), winds of
#: 150 m/s (the strongest gust measured 113) and their stress (about 100 N/m² by a bulk
#: formula at 150 m/s)
INPUT_BOUNDS: dict[str, float] = {
    "eta": 100.0, "pressure": 1026.0 * 9.81 * 100.0, "water_u": 10.0, "water_v": 10.0,
    "wind_u": 150.0, "wind_v": 150.0, "tau_x": 100.0, "tau_y": 100.0}


def coupling_grid(scene) -> Grid:
    """The exchange grid of ``[coupling.grid]``."""
    table = (scene.cfg.coupling or {}).get("grid")
    where = f"{scene.label}: [coupling.grid]"
    if table is None:
        raise SceneError(f"{scene.label}: a coupled run needs a [coupling.grid] table (the "
                         "exchange grid: kind, lon, lat, resolution)")
    try:
        cfg = GridCfg(**table)
    except ValueError as exc:
        raise SceneError(str(grid_error(exc, where))) from None
    try:
        return Grid(cfg, scene.cfg.planet.radius, table=f"{scene.label}: [coupling.grid]")
    except DataError as exc:
        raise SceneError(str(exc)) from None


def check_coupling(scene) -> None:
    """Validate ``[coupling]`` (its keys and its grid) before a run starts."""
    table = scene.cfg.coupling
    if table is None:
        return
    unknown = set(table) - {"grid", "write_output"}
    if unknown:
        raise SceneError(f"{scene.label}: [coupling] has unknown key(s) {sorted(unknown)}; "
                         "allowed: grid, write_output")
    if not isinstance(table.get("write_output", False), bool):
        raise SceneError(f"{scene.label}: [coupling] write_output must be true or false")
    coupling_grid(scene)


def element_polygons(ctx) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vertex longitudes, latitudes [deg], CSR offsets and centre longitudes [deg] of the
    elements of a running simulation."""
    from siku_core.geometry.quat import latlon_of
    from siku_core.geometry.element_geometry import polygons_lonlat

    st = ctx.state
    ll = polygons_lonlat(st.q, st.vert_offsets, st.verts, ctx.radius)
    nodes = np.concatenate(ll) if ll else np.zeros((0, 2))
    _, lon = latlon_of(st.q)
    return nodes[:, 0], nodes[:, 1], st.vert_offsets, np.degrees(lon)


def cell_gradient(grid: Grid, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gradient [1] of a cell field ``(ny, nx)`` [m] along the grid's x and y axes over true
    distances (central differences, one-sided at the edges; zero along an axis of one cell)."""
    ny, nx = grid.shape
    _, lat = grid.centres_lonlat
    R = grid.radius
    if grid.kind == "lonlat":
        dx = R * np.cos(np.radians(lat)) * np.radians(np.diff(grid.x_edges))[None, :]
        dy = R * np.radians(np.diff(grid.y_edges))[:, None] * np.ones((1, nx))
    else:
        k = 2.0 * grid.k0 / (1.0 + np.sin(np.radians(np.abs(lat))))  # map scale factor
        dx = np.diff(grid.x_edges)[None, :] / k
        dy = np.diff(grid.y_edges)[:, None] / k
    gx = np.zeros((ny, nx))
    gy = np.zeros((ny, nx))
    if nx > 1:
        gx = np.gradient(eta, axis=1) / dx
    if ny > 1:
        gy = np.gradient(eta, axis=0) / dy
    return gx, gy


#: the element–cell pairs of the exchange grid (:meth:`Exchange.refresh`, their producer)
CellOverlap = record_type("CellOverlap", __name__, [
    ("el", "i", 1, "element of each pair"),
    ("cell", "i", 1, "flat cell index (row-major over (ny, nx)) of each pair"),
    ("frac", "f", 1, "share of the element's area in the cell [1]"),
    ("ca", "f", 1, "cosine of the grid's x axis from east at the element's centre [1]"),
    ("sa", "f", 1, "sine of that angle [1]"),
], "The element–cell pairs of the exchange grid.")

#: the per-cell fields the pair forces read and the per-cell force record they add to
#: (:meth:`Exchange.add`, their producer), flat ``ny * nx`` arrays each
CellFields = record_type("CellFields", __name__, [
    ("gx", "f", 1, "slope of the sea surface along x [1]"),
    ("gy", "f", 1, "slope along y [1]"),
    ("wu", "f", 1, "water velocity along x [m/s]"),
    ("wv", "f", 1, "water velocity along y [m/s]"),
    ("tx", "f", 1, "force per area on the ice along x [N/m^2]"),
    ("ty", "f", 1, "force per area along y [N/m^2]"),
    ("au", "f", 1, "wind velocity along x [m/s]"),
    ("av", "f", 1, "wind velocity along y [m/s]"),
    ("fx", "f", 1, "sum of the pair forces on free elements along x [N] (recorded)"),
    ("fy", "f", 1, "the same along y [N]"),
], "The per-cell fields of the exchange grid and its per-cell force record.")


@njit(cache=True)
def _pair_forces(q, V, m, area, free, ov, cf, g, drag_coef, air_coef, F, record):
    """Pair forces of the module docstring (grid components) of the element–cell pairs ``ov``
    (:data:`CellOverlap`) from the cell fields ``cf`` (:data:`CellFields`), added to ``F`` [N]
    (local frames) and, if ``record``, to the per-cell sums ``cf.fx, cf.fy``. Elements:
    quaternions ``q``, velocities ``V`` [m/s], masses ``m`` [kg], areas ``area`` [m²], ``free``
    flags; ``g`` [m/s²]; ``drag_coef`` ``rho_w C`` and ``air_coef`` ``rho_a C_a`` [kg/m³]."""
    el = ov.el
    cell = ov.cell
    frac = ov.frac
    ca = ov.ca
    sa = ov.sa
    gx = cf.gx
    gy = cf.gy
    wu = cf.wu
    wv = cf.wv
    tx = cf.tx
    ty = cf.ty
    au = cf.au
    av = cf.av
    cfx = cf.fx
    cfy = cf.fy
    for p in range(el.shape[0]):
        e = el[p]
        c = cell[p]
        S = frac[p] * area[e]
        fx = -frac[p] * m[e] * g * gx[c] + S * tx[c]
        fy = -frac[p] * m[e] * g * gy[c] + S * ty[c]
        if air_coef > 0.0:
            wind_x, wind_y = quadratic_drag(S, air_coef, au[c], av[c])
            fx += wind_x
            fy += wind_y
        ex, ey, nx, ny = east_north_row(q, e)
        if drag_coef > 0.0:
            ue = V[e, 0] * ex + V[e, 1] * ey
            un = V[e, 0] * nx + V[e, 1] * ny
            ux = ue * ca[p] + un * sa[p]
            uy = -ue * sa[p] + un * ca[p]
            dx = wu[c] - ux
            dy = wv[c] - uy
            drag_x, drag_y = quadratic_drag(S, drag_coef, dx, dy)
            fx += drag_x
            fy += drag_y
        if free[e]:
            if record:
                cfx[c] += fx
                cfy[c] += fy
            fe = fx * ca[p] - fy * sa[p]
            fn = fx * sa[p] + fy * ca[p]
            F[e, 0] += fe * ex + fn * nx
            F[e, 1] += fe * ey + fn * ny


class Exchange(ForcingSource):
    """Forces on the ice from per-cell fields of the exchange grid (``[coupling.grid]``):
    slope of the sea surface, water drag, a force per area and wind drag; set by a coupled
    model through the BMI (``siku_io.coupling.bmi``), zero otherwise."""

    runs_on_ranks = False
    ranks_refusal = "its coupled model exchanges fields with one process"

    name = "exchange"
    #: read besides the parameters (the conformance suite cannot build the source without it)
    scene_tables = ("coupling.grid",)
    params: ClassVar[dict[str, Param]] = {
        "drag": Param(True, "", "water drag relative to the cells' water velocity", type=bool),
        **WATER_DRAG_PARAMS,
        "rho_air": Param(1.3, "kg/m^3", "air density rho_a", min=0.0),
        "C_air": Param(0.0016, "1", "air–ice drag coefficient C_a (eq. 21)", min=0.0),
        "g": Param(9.81, "m/s^2", "gravitational acceleration", min=0.0),
        "max_relative_speed": Param(
            1.0, "m/s", "largest expected ice–water speed, for the stable-time-step estimate",
            min=1e-6),
    }

    def setup(self, ctx):
        self.ctx = ctx
        self.st = ctx.state
        self.grid = coupling_grid(ctx.scene)
        self.C = drag_coefficient(self.p, self.name)
        ny, nx = self.grid.shape
        #: the input fields, ``(ny, nx)`` each (INPUTS); a coupled model sets them
        self.fields = {k: np.zeros((ny, nx)) for k in INPUTS}
        #: the input fields a coupled model has set (the floating process uses the pressure
        #: only once given)
        self.given: set[str] = set()
        self.free = self.st.flags == FREE
        self.cell_force = np.zeros((2, ny * nx))
        self.recorded = 0
        self._gx = self._gy = None
        self.refresh()

    def refresh(self) -> None:
        """Overlap of the elements with the cells at the current positions; restart the
        per-cell force record."""
        nl, nt, off, clon = element_polygons(self.ctx)
        el, cell, frac = self.grid.overlap(nl, nt, off, clon)
        from siku_core.geometry.quat import latlon_of

        lat, lon = latlon_of(self.st.q)
        a = self.grid.axes(np.degrees(lon), np.degrees(lat))[el]
        self.pairs = CellOverlap(el=np.ascontiguousarray(el), cell=np.ascontiguousarray(cell),
                                 frac=np.ascontiguousarray(frac), ca=np.cos(a), sa=np.sin(a))
        self.cell_force[:] = 0.0
        self.recorded = 0
        self.inputs_changed()

    def inputs_changed(self) -> None:
        """Recompute what depends on the input fields (the slope of the elevation)."""
        gx, gy = cell_gradient(self.grid, self.fields["eta"])
        self._gx, self._gy = np.ascontiguousarray(gx.ravel()), np.ascontiguousarray(gy.ravel())

    def mean_cell_force(self) -> np.ndarray:
        """``(2, ny, nx)`` [N]: per-cell force on the ice along x and y, mean over the steps
        recorded since the last :meth:`refresh` (zero before any)."""
        ny, nx = self.grid.shape
        return (self.cell_force / max(self.recorded, 1)).reshape(2, ny, nx)

    def add(self, t, q, V, w, F, T):
        p = self.p
        f = self.fields
        record = bool(self.ctx.committing)
        cf = CellFields(
            gx=self._gx if p["slope"] else np.zeros_like(self._gx),
            gy=self._gy if p["slope"] else np.zeros_like(self._gy),
            wu=np.ascontiguousarray(f["water_u"].ravel()),
            wv=np.ascontiguousarray(f["water_v"].ravel()),
            tx=np.ascontiguousarray(f["tau_x"].ravel()),
            ty=np.ascontiguousarray(f["tau_y"].ravel()),
            au=np.ascontiguousarray(f["wind_u"].ravel()),
            av=np.ascontiguousarray(f["wind_v"].ravel()),
            fx=self.cell_force[0], fy=self.cell_force[1])
        _pair_forces(q, V, self.st.m, self.st.area, self.free, self.pairs, cf, float(p["g"]),
                     self.C * p["rho"] if p["drag"] else 0.0, p["rho_air"] * p["C_air"], F,
                     record)
        if record:
            self.recorded += 1

    def stability_limit(self, ctx):
        """Explicit drag: ``dt < m / (S rho_w C |dU|)`` (as ``water_drag``)."""
        st = ctx.state
        if not self.p["drag"] or self.C * self.p["rho"] == 0:
            return None
        found = drag_stability_limit(st, st.flags == FREE, self.p["rho"], self.C,
                                     self.p["max_relative_speed"])
        if found is None:
            return None
        why = f"exchange drag (C = {self.C:.4g}, |dU| = {self.p['max_relative_speed']:g} m/s)"
        return found[0], why


def ice_fields(ctx, grid: Grid, eta: np.ndarray | None = None, rho_w: float = 1026.0,
               velocity_before: tuple[np.ndarray, np.ndarray] | None = None,
               interval: float = 0.0) -> dict[str, np.ndarray]:
    """What the ice gives the other model per cell (module docstring), ``(ny, nx)`` arrays:
    ``area_fraction`` [1], ``volume`` [m³], ``top``, ``bottom`` [m], ``u``, ``v`` [m/s], and
    ``ax``, ``ay`` [m/s²] from the element velocities ``velocity_before`` (grid components) an
    ``interval`` [s] ago (zero without them)."""

    ny, nx = grid.shape
    nc = ny * nx
    st = ctx.state
    nl, nt, off, clon = element_polygons(ctx)
    el, cell, frac = grid.overlap(nl, nt, off, clon)
    A = grid.cell_area.ravel()
    w = frac * st.area[el]
    wm = frac * st.m[el]
    ice = np.bincount(cell, w, nc)
    msum = np.bincount(cell, wm, nc)
    eta = np.zeros(nc) if eta is None else np.asarray(eta, float).ravel()
    rho_i = st.m / (st.area * st.thickness)
    draft = st.thickness * rho_i / rho_w
    top = eta.copy()
    bottom = eta.copy()
    if len(el):
        np.maximum.at(top, cell, eta[cell] + st.thickness[el] - draft[el])
        np.minimum.at(bottom, cell, eta[cell] - draft[el])
    gu, gv = grid_velocity(ctx, grid)
    out: dict[str, Any] = {"area_fraction": ice / A,
                           "volume": np.bincount(cell, w * st.thickness[el], nc),
                           "top": top, "bottom": bottom}
    # the mass-weighted cell means of a gridded file, with 0 rather than NaN in empty cells
    out["u"] = cell_means(cell, wm, msum, gu[el], 0.0)
    out["v"] = cell_means(cell, wm, msum, gv[el], 0.0)
    if velocity_before is not None and interval > 0:
        ax = (gu - velocity_before[0]) / interval
        ay = (gv - velocity_before[1]) / interval
        out["ax"] = cell_means(cell, wm, msum, ax[el], 0.0)
        out["ay"] = cell_means(cell, wm, msum, ay[el], 0.0)
    else:
        out["ax"] = np.zeros(nc)
        out["ay"] = np.zeros(nc)
    return {k: v.reshape(ny, nx) for k, v in out.items()}


def grid_velocity(ctx, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """Element velocities [m/s] along the grid's axes at their centres."""
    from siku_core.geometry.quat import latlon_of
    from siku_core.geometry.element_geometry import east_north

    st = ctx.state
    _, lon = latlon_of(st.q)
    return grid.rotate(*east_north(st.q, st.V), np.degrees(lon))


@hookimpl
def siku_register_forcing_sources():
    return [Exchange]


@hookimpl
def siku_configured(scene):
    """Check ``[coupling]`` before the run starts."""
    check_coupling(scene)
