"""``spectral``: a wave field whose spectrum evolves over a grid and is damped by the ice.

The incident sea (``spectrum = "jonswap"``, ``"monochromatic"`` or ``"table"``) is a set of
components ``j`` (frequency, direction, phase) as in :mod:`siku_forcing.waves.wave_field`. Over a
regular
grid in the field's plane (``x`` east, ``y`` north of ``origin`` [m]) the variance ``E_j`` [m²]
of every component evolves by the energy balance of :mod:`siku_forcing.waves.spectral_transport`,
``∂E/∂t + ∇·(c_g E) = -2 c_g k_i C E``, with the amplitude attenuation rate ``k_i`` of an
attenuation law (plugin kind ``attenuation_law``, ``siku_forcing.waves.attenuation``) and the ice
concentration ``C`` and thickness ``h`` of each cell computed from the elements: ``C`` = the
area of the elements whose centres lie in the cell over the cell's area (at most 1), ``h`` =
their area-weighted mean thickness. The incident spectrum enters across the open edges of the
grid (``boundary = "open"``) or nothing crosses them (``"closed"``).

The elements feel the local sea: at a point in cell ``c`` the component ``j`` has the amplitude
``a_j = sqrt(2 E_j[c])`` and the phase of the incident component, ``psi_j = k_j·x - omega_j t +
phi_j``; elevation, slope, orbital velocity and curvature are the sums of
:mod:`siku_forcing.waves.wave_field` with these amplitudes, so the ``waves`` forcing (drag, slope
force,
flexural breaking) acts as with a uniform sea, and so does a ``floating`` process, which shares
this instance (:attr:`Spectral.local_sea`) and loads each element with the amplitudes of its
cell (``siku_plugins.floating.process``). Points outside the grid take the nearest cell.

On MPI ranks (``siku_core.ranks``) every rank evolves the run's spectrum alike: at each step
the engine commits, the rank's view of the field (:class:`RankSpectral`) gathers from their
owners the positions, thickness and flags of every element and the power their response took
(``RankLink.whole``), so the cells' ice and sums over the elements run in global element order,
as on one rank; each rank then forces its own elements (owned and ghosts) from their cells and
sets their fields, and gathers their drag power for the next step and the diagnostics.

The sea advances when the engine commits a step (the first force evaluation of a step), in as
many equal sub-steps as the Courant limit ``cfl`` asks. Per element the field reports
``wave_height`` (significant height ``4 sqrt(sum E)`` of its cell [m]), ``wave_dissipation``
(the power the ice absorbs per unit area in its cell, ``rho g sum 2 c_g k_i C E`` [W m-2], the
parameterised loss) and ``wave_drag_power`` (the rate of work of the element's wave drag
against the orbital flow per unit area, ``F_drag · u / S`` [W m-2], the loss the ice's own
response takes, to set beside the parameterised one; the transport does not subtract it);
their totals are diagnostics. ``wave_attenuation`` and ``wave_response_attenuation`` [1/m] are
the rates ``k = P / (2 rho g sum c_g E)`` of the element's cell for the law's ``P`` and for the
power the ice's response takes (drag and a ``floating`` process's radiation damping):
:meth:`Spectral.attenuations`. What the transport does not represent: wind
input, nonlinear transfer, whitecapping, refraction, reflection and scattering into other
directions; the ice changes the amplitude only, never the wavelength or the group velocity.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numba import njit

from siku_core import Param, SceneError, hookimpl
from siku_core.run.limits import physical_memory
from siku_core.fields import ElementField

from .spectral_transport import absorb, transport
from .wave_kernels import add_slope_drag, plane_coords, wrap_phase  # noqa: F401 - re-exported
from .wave_field import Jonswap, LinearWave, WaveField

RHO_WATER = 1025.0


@njit(cache=True)
def _cell_sums(t, lat, lon, cell, w, amp, uo, se, sn, curv):
    """Per point: eta, slope east/north, orbital u east/north (``curv`` False), or the
    curvature along ``(se, sn)`` (``curv`` True), of the sea ``w``
    (:data:`siku_forcing.waves.wave_field.PlaneWaves`: its plane, wavenumbers, frequencies and
    phases)
    with the amplitudes ``amp[cell[i], j]`` [m] and orbital speeds ``uo[cell[i], j]`` [m/s]
    of each point's cell."""
    lat0, lon0, R = w.lat0, w.lon0, w.R
    kx, ky, om, ph = w.kx, w.ky, w.omega, w.phase
    n = lat.shape[0]
    out = np.zeros((n, 5))
    c0 = math.cos(lat0)
    for i in range(n):
        d = wrap_phase(lon[i] - lon0)
        x = R * c0 * d
        y = R * (lat[i] - lat0)
        m = c0 / max(math.cos(lat[i]), 1e-12)
        c = cell[i]
        for j in range(kx.shape[0]):
            a = amp[c, j]
            if a == 0.0:
                continue
            psi = kx[j] * x + ky[j] * y - om[j] * t + ph[j]
            cs = math.cos(psi)
            if curv:
                ks = kx[j] * m * se[i] + ky[j] * sn[i]
                out[i, 0] -= a * ks * ks * cs
                continue
            s = math.sin(psi)
            k = math.sqrt(kx[j] * kx[j] + ky[j] * ky[j])
            out[i, 0] += a * cs
            out[i, 1] -= a * kx[j] * m * s
            out[i, 2] -= a * ky[j] * s
            out[i, 3] += uo[c, j] * cs * kx[j] * m / k
            out[i, 4] += uo[c, j] * cs * ky[j] / k
    return out


@njit(cache=True)
def _element_cells(q, lat0, lon0, R, x0, y0, dx, dy, nx, ny):
    """:meth:`Spectral.cells` of the centres of elements at orientations ``q``, in one pass
    (the same arithmetic as ``latlon_of``, ``plane_coords`` and the floors: the same cells)."""
    n = q.shape[0]
    out = np.empty(n, dtype=np.int64)
    c0 = math.cos(lat0)
    for i in range(n):
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        cx = 2 * (x * z + w * y)
        cy = 2 * (y * z - w * x)
        cz = 1 - 2 * (x * x + y * y)
        lat = math.atan2(cz, math.hypot(cx, cy))
        lon = math.atan2(cy, cx)
        ix = math.floor((R * c0 * wrap_phase(lon - lon0) - x0) / dx)
        iy = math.floor((R * (lat - lat0) - y0) / dy)
        out[i] = min(max(iy, 0), ny - 1) * nx + min(max(ix, 0), nx - 1)
    return out


class Spectral(WaveField):
    """A wave spectrum that evolves over a grid and is damped by the ice (module docstring)."""

    name = "spectral"
    #: the sea differs from cell to cell: a ``floating`` process shares this instance (the run's,
    #: ``Context.forcing_field``) and loads each element with its cell's amplitudes
    #: (:meth:`amplitudes`, :meth:`cells`)
    local_sea = True
    #: on MPI ranks the run's instance evolves alike on every rank (:meth:`on_rank`): its
    #: spectrum and clock are the same everywhere
    rank_history: ClassVar[dict[str, str]] = {"E": "same", "t_wave": "same"}
    params: ClassVar[dict[str, Param]] = {
        "spectrum": Param("jonswap", "", "incident sea: jonswap, monochromatic or table",
                          type=str, choices=("jonswap", "monochromatic", "table")),
        "hs": Param(1.0, "m", "jonswap: significant wave height", min=0.0),
        "tp": Param(8.0, "s", "jonswap: peak period", min=1e-3),
        "gamma": Param(3.3, "1", "jonswap: peak enhancement factor", min=1.0),
        "spreading": Param(10.0, "1", "jonswap: spreading exponent s of cos^2s", min=0.0,
                           max=1e4),
        "n_frequencies": Param(24, "1", "jonswap: frequency bins", type=int, min=1, max=1024),
        "n_directions": Param(1, "1", "jonswap: direction bins (1: unidirectional)", type=int,
                              min=1, max=360),
        "f_low": Param(0.5, "1", "jonswap: lowest frequency over the peak's", min=0.01),
        "f_high": Param(4.0, "1", "jonswap: highest frequency over the peak's", min=1.0),
        "seed": Param(-1, "1", "random seed of the phases (-1: the scene's [run] seed)",
                      type=int, min=-1),
        "amplitude": Param(0.5, "m", "monochromatic: amplitude", min=0.0),
        "period": Param(8.0, "s", "monochromatic: period", min=1e-3),
        "frequencies": Param([], "Hz", "table: bin centres (equal widths)", type=list),
        "energy": Param([], "m2 Hz-1", "table: spectral density S(f) of each bin", type=list),
        "direction": Param(90.0, "deg", "(mean) direction of travel, clockwise from north"),
        "x": Param(None, "m", "grid extent east of the origin [x0, x1] (required)", type=list),
        "y": Param(None, "m", "grid extent north of the origin [y0, y1] (required)",
                   type=list),
        "resolution": Param(100.0, "m", "cell size (a y extent of one cell: a 1-D flume)",
                            min=1e-3),
        "boundary": Param("open", "", "open (the incident sea enters) or closed (no flux)",
                          type=str, choices=("open", "closed")),
        "start": Param("incident", "", "initial sea: incident (everywhere) or calm", type=str,
                       choices=("incident", "calm")),
        "attenuation": Param("constant", "", "attenuation law (siku plugins attenuation_law)",
                             type=str),
        "attenuation_params": Param({}, "1", "parameters of the attenuation law (their units: "
                                    "siku plugins attenuation_law)", type=dict),
        "cfl": Param(0.9, "1", "Courant number of the transport sub-steps (from 0.1: the upwind "
                     "scheme's diffusion (1 - cfl) c dx / 2 is then within 10 % of its limit)",
                     min=0.1, max=1.0),
        **WaveField.common,
    }
    owned_fields = (
        ElementField("wave_height", "m", "significant wave height 4 sqrt(sum E) of the "
                     "element's cell of the spectral wave field"),
        ElementField("wave_dissipation", "W m-2", "wave power absorbed by the ice per unit "
                     "area in the element's cell, rho g sum 2 c_g k_i C E"),
        ElementField("wave_drag_power", "W m-2", "rate of work of the wave drag on the "
                     "element against the orbital flow, F_drag . u_orbital / area (power the "
                     "waves lose to the element's drag)"),
        ElementField("wave_attenuation", "m-1", "the law's amplitude attenuation rate in the "
                     "element's cell, C k_i weighted by the energy flux c_g E of the "
                     "components"),
        ElementField("wave_response_attenuation", "m-1", "amplitude attenuation rate the "
                     "ice's response implies in the element's cell: the drag and radiated "
                     "power of its elements over 2 rho g sum c_g E"),
    )
    diagnostic_units: ClassVar[dict[str, str]] = {
        "wave_power_absorbed": "W", "wave_energy": "J", "wave_drag_power": "W"}
    seed = 0

    # ------------------------------------------------------------------ set up
    def components(self):
        p = self.p
        sea = p["spectrum"]
        if sea == "monochromatic":
            w = LinearWave({**{k: q.default for k, q in LinearWave.params.items()},
                            "amplitude": p["amplitude"], "period": p["period"],
                            "direction": p["direction"]})
            return w.components()
        if sea == "table":
            return self._table()
        j = Jonswap({**{k: q.default for k, q in Jonswap.params.items()},
                     **{k: p[k] for k in ("hs", "tp", "gamma", "direction", "spreading",
                                          "n_frequencies", "n_directions", "f_low", "f_high",
                                          "seed", "g")}})
        j.seed = self.seed
        return j.components()

    def _table(self):
        f = np.asarray(self.p["frequencies"], float)
        S = np.asarray(self.p["energy"], float)
        where = self.where()
        if f.ndim != 1 or f.shape != S.shape or len(f) == 0:
            raise SceneError(f"{where}: 'frequencies' and 'energy' must be lists of the same "
                             "length, at least one bin")
        if not (np.isfinite(S).all() and np.isfinite(f).all()):
            raise SceneError(f"{where}: 'frequencies' and 'energy' must be finite")
        if (S < 0).any():
            i = int(np.flatnonzero(S < 0)[0])
            raise SceneError(f"{where}: 'energy' bin {i} is {S[i]:g} m2/Hz: a spectrum holds "
                             "no negative energy")
        if (f <= 0).any() or (len(f) > 1 and (np.diff(f) <= 0).any()):
            raise SceneError(f"{where}: 'frequencies' must be positive and increasing")
        df = np.gradient(f) if len(f) > 1 else np.ones(1)
        amp = np.sqrt(2.0 * S * df)
        rng = np.random.default_rng([self.seed if self.p["seed"] < 0 else self.p["seed"], 2004])
        return (amp, 2 * np.pi * f, np.full(len(f), float(self.p["direction"])),
                rng.uniform(0, 2 * np.pi, len(f)))

    def setup(self, ctx):
        self.ctx = ctx
        super().setup(ctx)
        p = self.p
        where = self.where()
        dx = float(p["resolution"])
        ok = all(isinstance(v, list) and len(v) == 2 and all(
            isinstance(e, (int, float)) and math.isfinite(e) for e in v) for v in (p["x"], p["y"]))
        if not ok or not (p["x"][1] > p["x"][0] and p["y"][1] > p["y"][0]):
            raise SceneError(f"{where}: 'x' and 'y' must be [low, high] in metres with high > "
                             "low")
        (x0, x1), (y0, y1) = p["x"], p["y"]
        if p["boundary"] == "closed" and p["start"] == "calm":
            raise SceneError(f"{where}: boundary = 'closed' with start = 'calm': no sea ever "
                             "enters the grid; open the boundary or start from the incident sea")
        self.dx = dx
        self.nx = max(1, int(round((x1 - x0) / dx)))
        self.ny = max(1, int(round((y1 - y0) / dx)))
        self.dy = (y1 - y0) / self.ny
        self.dx = (x1 - x0) / self.nx
        self.x0, self.y0 = float(x0), float(y0)
        self.law = ctx.component("attenuation_law", p["attenuation"], p["attenuation_params"],
                                 f"{self.table}.attenuation" if self.table else "attenuation")
        self.f = self.omega / (2 * np.pi)
        from .attenuation import group_velocity

        self.cg = np.asarray(group_velocity(self.omega, self.h, p["g"]), float) * np.ones(
            len(self.omega))
        kk = np.hypot(self.kx, self.ky)
        self.cx, self.cy = self.cg * self.kx / kk, self.cg * self.ky / kk
        # a direction along an axis travels along it only (sin 90° is 6e-17 off in floating
        # point: without this a flume would leak the incident sea in across its sides)
        self.cx[np.abs(self.cx) < 1e-12 * self.cg] = 0.0
        self.cy[np.abs(self.cy) < 1e-12 * self.cg] = 0.0
        self.E_in = 0.5 * self.amp**2
        shape = (len(self.amp), self.ny, self.nx)
        # the spectrum, its transported copy and the two fluxes: 32 bytes per bin and cell
        need, ram = 32.0 * len(self.amp) * self.nx * self.ny, physical_memory()
        if ram and need > ram / 2:
            raise SceneError(
                f"{where}: resolution = {dx:g} m makes a grid of {self.nx} × {self.ny} cells of "
                f"{len(self.amp)} bins, {need / 2**30:.3g} GiB, more than half of this "
                f"machine's {ram / 2**30:.3g} GiB; allowed: resolution at least "
                f"{dx * math.sqrt(2 * need / ram):.4g} m (or fewer bins, a smaller x, y)")
        self.E = np.zeros(shape) + (self.E_in[:, None, None] if p["start"] == "incident"
                                    else 0.0)
        self.t_wave = 0.0
        st = ctx.state
        cells, inside = self.cells(*self._latlon(st.q))
        if not inside.all():
            bad = np.flatnonzero(~inside)
            raise SceneError(f"{where}: the grid x = {p['x']}, y = {p['y']} m does not cover "
                             f"the ice: element {int(bad[0])} (and {len(bad) - 1} more) lies "
                             "outside it")
        self._ice(st.q)

    @staticmethod
    def _latlon(q):
        from siku_core.geometry.quat import latlon_of

        return latlon_of(q)

    def cells(self, lat, lon):
        """Cell index (``iy * nx + ix``, clipped to the grid) of points ``lat, lon`` [rad] and
        whether each lies inside the grid."""
        x, y = plane_coords(np.ascontiguousarray(lat, float), np.ascontiguousarray(lon, float),
                      self.lat0, self.lon0, self.radius)
        ix = np.floor((x - self.x0) / self.dx).astype(np.int64)
        iy = np.floor((y - self.y0) / self.dy).astype(np.int64)
        inside = (ix >= 0) & (ix < self.nx) & (iy >= 0) & (iy < self.ny)
        return np.clip(iy, 0, self.ny - 1) * self.nx + np.clip(ix, 0, self.nx - 1), inside

    def element_cells(self, q) -> np.ndarray:
        """The cell (clipped to the grid) of the centre of every element at orientation ``q``:
        :meth:`cells` of their positions, in one compiled pass."""
        return _element_cells(q, self.lat0, self.lon0, float(self.radius), self.x0, self.y0,
                              self.dx, self.dy, self.nx, self.ny)

    def _ice(self, q, thickness=None, flags=None):
        """Concentration, thickness and attenuation rate per cell from the elements at
        orientation ``q`` (every element of the run) with ``thickness`` [m] and ``flags``
        (default: the run's state's); the cell of every element."""
        st = self.ctx.state
        thickness = st.thickness if thickness is None else thickness
        flags = st.flags if flags is None else flags
        cell, _ = self.cells(*self._latlon(q))
        nc = self.nx * self.ny
        live = flags != 3  # melted elements hold no ice
        a = np.where(live, st.area, 0.0)
        area = np.bincount(cell, a, nc)
        self.C = np.minimum(area / (self.dx * self.dy), 1.0).reshape(self.ny, self.nx)
        h = np.bincount(cell, a * thickness, nc) / np.where(area > 0, area, 1.0)
        self.h_ice = h.reshape(self.ny, self.nx)
        # the law's rate depends on the thickness only: kept while no cell's thickness changes
        # (ice that does not move or grow: the rate of every step would be the same array)
        if getattr(self, "_ki_h", None) is None or not np.array_equal(self._ki_h, self.h_ice):
            self.ki = np.asarray(self.law.rate(self.f[:, None, None], self.h_ice[None],
                                               self.h), float) * np.ones(self.E.shape)
            self._ki_h = self.h_ice
        self.element_cell = cell

    # ------------------------------------------------------------------ evolution
    def advance(self, t: float, q=None, thickness=None, flags=None) -> None:
        """Evolve the spectrum from its time to ``t`` [s] (nothing if ``t`` is not later), with
        the ice of orientation ``q``, ``thickness`` [m] and ``flags`` (every element of the
        run; the current state's by default)."""
        if t <= self.t_wave:
            return
        self._ice(self.ctx.state.q if q is None else q, thickness, flags)
        rate = np.max(np.abs(self.cx) / self.dx + np.abs(self.cy) / self.dy)
        n = max(1, int(math.ceil((t - self.t_wave) * rate / self.p["cfl"] - 1e-12)))
        dt = (t - self.t_wave) / n
        closed = self.p["boundary"] == "closed"
        for _ in range(n):
            self.E, _ = transport(self.E, self.cx, self.cy, self.dx, self.dy, dt, closed,
                                  self.E_in)
            self.E, _ = absorb(self.E, self.cg, self.ki, self.C, dt)
        self.t_wave = float(t)
        self._amp_cells = None

    def dissipation(self) -> np.ndarray:
        """Power absorbed by the ice per unit area [W/m²] per cell, ``(ny, nx)``: ``rho g sum_j
        2 c_g k_i C E_j``."""
        s = 2.0 * self.cg[:, None, None] * self.ki * self.C[None] * self.E
        return RHO_WATER * self.p["g"] * s.sum(axis=0)

    def height(self) -> np.ndarray:
        """Significant wave height ``4 sqrt(sum_j E_j)`` [m] per cell, ``(ny, nx)``."""
        return 4.0 * np.sqrt(np.maximum(self.E.sum(axis=0), 0.0))

    def amplitudes(self) -> tuple[np.ndarray, np.ndarray]:
        """``(amp, uo)``, ``(C, M)`` each: the amplitude ``sqrt(2 E_j)`` [m] and the orbital
        speed [m/s] of every component in every cell (``C = nx ny``, row ``iy nx + ix``), as
        the spectrum is now."""
        if getattr(self, "_amp_cells", None) is None:
            nc = self.nx * self.ny
            a = np.sqrt(2.0 * np.maximum(self.E, 0.0)).reshape(len(self.amp), nc).T
            self._amp_cells = np.ascontiguousarray(a)
            # orbital speed over amplitude, omega coth(k h): an incident sea another model
            # sets (E_in, siku_io.coupling.waves) keeps it
            ratio = self.omega / np.tanh(self.k * self.h) if math.isfinite(self.h) else \
                self.omega
            self._uo_cells = np.ascontiguousarray(a * ratio[None, :])
        return self._amp_cells, self._uo_cells

    # ------------------------------------------------------------------ the sea at points
    def _sums(self, t, lat, lon, se=None, sn=None):
        lat = np.ascontiguousarray(lat, float)
        lon = np.ascontiguousarray(lon, float)
        cell, _ = self.cells(lat, lon)
        amp, uo = self.amplitudes()
        curv = se is not None
        z = np.zeros(len(lat))
        return _cell_sums(float(t), lat, lon, cell, self.plane_waves(), amp, uo,
                          z if se is None else np.ascontiguousarray(se, float),
                          z if sn is None else np.ascontiguousarray(sn, float), curv)

    def sample(self, t, lat, lon):
        """Orbital velocity east, north [m/s] of the local sea (a drag that takes this field
        as its current); the sea advances when the engine commits a step."""
        if self.ctx.committing:
            self._commit_step(t, None)
        r = self.evaluate(t, lat, lon)
        return r["u"], r["v"]

    def evaluate(self, t, lat, lon):
        r = self._sums(t, lat, lon)
        return {"eta": r[:, 0], "eta_e": r[:, 1], "eta_n": r[:, 2], "u": r[:, 3], "v": r[:, 4]}

    def curvature(self, t, lat, lon, se, sn):
        return self._sums(t, lat, lon, se, sn)[:, 0]

    def add_forces(self, t, q, V, st, free, g, slope, drag, F, view=None) -> None:
        """The ``waves`` forcing with the local sea: advance the spectrum when the engine
        commits a step, then add ``-m g grad eta`` and the drag ``S drag |u - U| (u - U)`` to
        the free elements (local frames), as :func:`siku_forcing.waves.wave_field.wave_forces`.
        ``view``: the :class:`RankSpectral` of an MPI rank's engine whose elements ``q`` are
        (``None``: every element of the run)."""
        ctx = self.ctx if view is None else view.ctx
        committing = ctx.committing
        if committing:
            self._commit_step(t, q, view)
        if drag == 0.0 and not slope:  # no force: the sea acts on the ice by breaking only
            if committing:
                self.drag_power = np.zeros(self.ctx.state.n)
                if "wave_drag_power" in ctx.fields:
                    ctx.fields["wave_drag_power"][:] = 0.0
            return
        lat, lon = self._latlon(q)
        r = self._sums(t, lat, lon)
        power = np.zeros(len(q))
        add_slope_drag(q, V, st.m, st.area, free, r, g, slope, drag, F, power)
        if committing:
            # the run's, every element's (on a rank: from their owners) for the diagnostics
            # and the next step's response power
            self.drag_power = power if view is None else view.link.whole(power)[0]
            fields = ctx.fields
            if "wave_drag_power" in fields:
                fields["wave_drag_power"][:] = power / st.area

    def _commit_step(self, t, q, view=None) -> None:
        """At the force evaluation that commits a step: the spectrum advanced to ``t`` [s]
        with the ice at orientation ``q`` (``None``: the state's), and the fields of the
        elements set from their cells. ``view``: as :meth:`add_forces` (the rank's elements
        ``q``; every element's ice then gathered from its owner)."""
        if view is None:
            self.advance(t, q)
            self._report()
            return
        q_all, h_all, flags_all, power = view.whole_ice(q)
        self.advance(t, q_all, h_all, flags_all)
        self._report(view.ctx.fields, view.link.ids, power)

    def _report(self, fields=None, rows=None, power=None):
        """The fields of the elements from their cells: of every element of the run in
        ``fields`` (default: the run's), or of the run's elements ``rows`` (a rank's); ``power``
        [W] per element of the run: :meth:`response_power` by default."""
        fields = self.ctx.fields if fields is None else fields
        if "wave_height" in fields:
            c = self.element_cell if rows is None else self.element_cell[rows]
            fields["wave_height"][:] = self.height().ravel()[c]
            fields["wave_dissipation"][:] = self.dissipation().ravel()[c]
            k_law, k_resp = self.attenuations(self.response_power() if power is None
                                              else power)
            fields["wave_attenuation"][:] = k_law.ravel()[c]
            fields["wave_response_attenuation"][:] = k_resp.ravel()[c]

    def response_power(self, radiated=None) -> np.ndarray:
        """Power [W] per element that the ice's own motion takes from the waves over the last
        step: its drag's work against the orbital flow (``wave_drag_power``) plus the radiation
        damping's work of a ``floating`` process (``wave_radiated_power`` [W m-2], of every
        element: ``radiated``, default the run's field, if the scene has one), both times the
        element's area."""
        st = self.ctx.state
        power = np.zeros(st.n) + getattr(self, "drag_power", 0.0)
        if radiated is None and "wave_radiated_power" in self.ctx.fields:
            radiated = self.ctx.fields["wave_radiated_power"]
        if radiated is not None:
            power += radiated * st.area
        return power

    def attenuations(self, power) -> tuple[np.ndarray, np.ndarray]:
        """The amplitude attenuation rates [1/m] per cell ``(ny, nx)`` of the law and of the
        ice's response to ``power`` [W] per element, both defined by the energy balance:
        ``d(c_g E)/dx = -2 k c_g E`` makes the power absorbed per unit area ``P = 2 k rho g
        c_g E`` for one component, so for the spectrum ``k = P / (2 rho g sum_j c_g E_j)``, the
        rates weighted by the energy flux. The law's ``P`` is :meth:`dissipation` (so its
        ``k`` is the flux-weighted mean of ``C k_i``); the response's is ``power`` summed over
        the elements whose centres lie in the cell, over the cell's area. Zero in a cell
        without wave energy."""
        flux = 2.0 * RHO_WATER * self.p["g"] * np.einsum("j,jyx->yx", self.cg, self.E)
        nc = self.nx * self.ny
        p_resp = np.bincount(self.element_cell, power, nc).reshape(self.ny, self.nx) / (
            self.dx * self.dy)
        ok = flux > 0
        den = np.where(ok, flux, 1.0)
        return (np.where(ok, self.dissipation() / den, 0.0), np.where(ok, p_resp / den, 0.0))

    # ------------------------------------------------------------------ bookkeeping
    def diagnostics(self, ctx):
        cell = self.dx * self.dy
        return {"wave_power_absorbed": float(self.dissipation().sum() * cell),
                "wave_energy": float(RHO_WATER * self.p["g"] * self.E.sum() * cell),
                "wave_drag_power": float(np.sum(getattr(self, "drag_power", 0.0)))}

    def on_rank(self, ctx, link) -> "RankSpectral":
        """The field as the engine of an MPI rank evaluates it: a :class:`RankSpectral` view of
        this instance (the run's, whose spectrum every rank evolves alike)."""
        return RankSpectral(self, ctx, link)

    def history(self):
        return {"E": self.E.copy(), "t_wave": np.array(self.t_wave)}

    def set_history(self, arrays):
        if arrays["E"].shape != self.E.shape:
            raise SceneError(f"{self.where()}: restart holds a spectrum of shape "
                             f"{arrays['E'].shape}, the scene builds {self.E.shape}")
        self.E = np.array(arrays["E"], float)
        self.t_wave = float(arrays["t_wave"])
        self._amp_cells = None


class RankSpectral:
    """The run's :class:`Spectral` field (``run``) as the engine of an MPI rank evaluates it
    (``siku_core.ranks``): ``ctx`` the engine's context over the elements the rank holds
    (owned and ghosts, ascending global index), ``link`` its place in the run
    (``siku_core.ranks.local.RankLink``). At each step the engine commits it gathers every
    element's ice from its owner (:meth:`whole_ice`, a collective call every rank makes
    alike), so that the run's instance advances the spectrum as on one rank, and sets the
    fields of the rank's elements from their cells; everything else is the run's field's
    (the sea at points, its components, its spectrum and clock)."""

    def __init__(self, run: Spectral, ctx, link):
        self.run, self.ctx, self.link = run, ctx, link

    def __getattr__(self, name):
        if name == "run":  # (before ``__init__``: a copy being made)
            raise AttributeError(name)
        return getattr(self.run, name)

    def whole_ice(self, q) -> tuple[np.ndarray, ...]:
        """``(q, thickness [m], flags, power [W])`` of every element of the run, from the
        owners' rows of the rank's ``q`` (its elements' orientations now), state and fields:
        ``power`` is :meth:`Spectral.response_power` (the last step's drag power and the
        radiated power of a ``floating`` process). Collective."""
        st, fields = self.ctx.state, self.ctx.fields
        radiated = fields.get("wave_radiated_power")
        got = self.link.whole(q, st.thickness, st.flags,
                              *(() if radiated is None else (radiated,)))
        power = self.run.response_power(got[3] if radiated is not None else None)
        return got[0], got[1], got[2], power

    def add_forces(self, t, q, V, st, free, g, slope, drag, F) -> None:
        """:meth:`Spectral.add_forces` on the rank's elements."""
        self.run.add_forces(t, q, V, st, free, g, slope, drag, F, view=self)

    def sample(self, t, lat, lon):
        """:meth:`Spectral.sample` at the rank's points; the sea advances when the rank's
        engine commits a step (with its elements' state)."""
        if self.ctx.committing:
            self.run._commit_step(t, self.ctx.state.q, self)
        r = self.run.evaluate(t, lat, lon)
        return r["u"], r["v"]


@hookimpl
def siku_register_fields():
    return [Spectral]
