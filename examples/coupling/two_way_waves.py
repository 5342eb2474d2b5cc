"""Waves and ice coupled both ways through the BMI: a small wave model written for this example.

``FlumeWaves`` is a long-crested, deep-water linear wave entering a flume from the west. Under
ice its amplitude decays as ``dA/dx = -alpha c(x) A``, ``c`` the ice area fraction siku reports
on the exchange grid (the mean over the flume's width): ice -> waves. From ``A(x)`` it gives the
surface elevation ``eta = A cos(kx - wt)`` and the surface orbital velocity ``u = A w cos(kx -
wt)`` at the cell centres, which siku turns into slope and drag forces on the ice: waves -> ice.
Fields are exchanged every ``exchange_every`` seconds (the wave fields at the middle of each
interval, held over it).

So the ice shelters itself: floes at the ice edge surge with nearly the incident wave, floes deep
in the pack with a wave that the pack in front of them has damped.

Run ``python examples/coupling/two_way_waves.py [OUT.png]`` (draws ``two_way_waves.png`` in the
working directory; ``docs/gallery/make_gallery.py`` draws the gallery's copy).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
R = 6_371_000.0


class FlumeWaves:
    """The wave model of the module docstring on cell centres ``x`` [m] (west to east)."""

    def __init__(self, x, amplitude=0.3, period=10.0, alpha=4e-3, g=9.81):
        self.x = np.asarray(x, float)
        self.a0, self.omega, self.alpha = amplitude, 2 * np.pi / period, alpha
        self.k = self.omega**2 / g
        self.A = np.full(len(x), amplitude)

    def set_ice(self, concentration):
        """Ice area fraction ``(ny, nx)`` -> amplitude along the flume (midpoint rule per
        cell: ``A_j = a0 exp(-alpha (sum_{i<j} c_i dx + c_j dx / 2))``)."""
        c = np.asarray(concentration).mean(axis=0)
        dx = np.gradient(self.x)
        loss = np.cumsum(c * dx) - 0.5 * c * dx
        self.A = self.a0 * np.exp(-self.alpha * loss)

    def fields(self, t, ny):
        """Elevation [m] and orbital velocity [m/s] at time ``t`` [s], ``(ny, nx)`` each."""
        c = np.cos(self.k * self.x - self.omega * t)
        eta = self.A * c
        u = self.A * self.omega * c
        return np.tile(eta, (ny, 1)), np.tile(u, (ny, 1))


def run(scene=HERE / "waves_ice.toml", duration=None, exchange_every=0.5, alpha=4e-3):
    """Run the coupled system; returns ``(ice BMI (finalized), waves, record)`` with ``record``
    holding per exchange the time [s] and the ice velocities along the flume [m/s]."""
    from siku_core.geometry.quat import latlon_of
    from siku_io.coupling.bmi import SikuBmi
    from siku_core.geometry.element_geometry import east_north

    ice = SikuBmi()
    ice.initialize(str(scene))
    ny, nx = ice.get_grid_shape(0, np.zeros(2, dtype=int))
    lon = ice.get_grid_x(0, np.zeros(nx))
    x = R * np.radians(lon - lon[0])  # the flume lies on the equator
    waves = FlumeWaves(x, alpha=alpha)
    n = ny * nx
    conc = ice.get_value("sea_ice__area_fraction", np.zeros(n)).reshape(ny, nx)
    waves.set_ice(conc)
    end = ice.get_end_time() if duration is None else duration
    times, speeds = [], []
    t = ice.get_current_time()
    while t < end - 1e-9:
        eta, u = waves.fields(t + 0.5 * exchange_every, ny)
        ice.set_value("sea_water_surface__elevation", eta.ravel())
        ice.set_value("sea_water_flowing__x_component_of_velocity", u.ravel())
        ice.update_until(t + exchange_every)
        t = ice.get_current_time()
        conc = ice.get_value("sea_ice__area_fraction", np.zeros(n)).reshape(ny, nx)
        waves.set_ice(conc)
        ue, _ = east_north(ice.sim.state.q, ice.sim.state.V)
        times.append(t)
        speeds.append(ue.copy())
    _, elon = latlon_of(ice.sim.state.q)
    record = {"time": np.array(times), "u": np.array(speeds),
              "x": R * (elon - np.radians(lon[0]))}
    ice.finalize()
    return ice, waves, record


def surge(record, x0, x1):
    """Standard deviation [m/s] of the east velocity of the floes between ``x0`` and ``x1``
    [m] over the second half of the run."""
    sel = (record["x"] >= x0) & (record["x"] < x1)
    half = record["time"] >= record["time"][-1] / 2
    return float(record["u"][half][:, sel].std())


def main(out="two_way_waves.png"):  # pragma: no cover - a demonstration
    """Run the coupled flume with and without damping; draw ``out`` (in the working
    directory: nothing is written beside this file)."""
    import matplotlib.pyplot as plt

    _, waves, rec = run()
    _, calm, rec0 = run(alpha=0.0)
    edges = np.linspace(500.0, 1000.0, 11)
    mids = 0.5 * (edges[1:] + edges[:-1])
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    a1.plot(waves.x, waves.A, label="damped by the ice siku reports")
    a1.plot(calm.x, calm.A, "--", label="no damping (alpha = 0)")
    a1.axvspan(500, 1000, color="0.9", label="ice")
    a1.set_ylabel("wave amplitude [m]")
    a1.legend()
    a2.plot(mids, [surge(rec, a, b) for a, b in zip(edges[:-1], edges[1:])], "o-",
            label="coupled")
    a2.plot(mids, [surge(rec0, a, b) for a, b in zip(edges[:-1], edges[1:])], "s--",
            label="no damping")
    a2.set_xlabel("distance along the flume [m]")
    a2.set_ylabel("floe surge speed (std) [m/s]")
    a2.legend()
    fig.suptitle("Waves and ice coupled through the BMI")
    fig.tight_layout()
    fig.savefig(out, dpi=150)
    print("wrote", out)


if __name__ == "__main__":  # pragma: no cover
    main(*sys.argv[1:2])
