"""The floating process's incident wave from a coupled model through the BMI (``wave =
"exchange"``, ``siku_plugins.floating.coupled``): a damped block settles where the elevation
or, once given, the dynamic pressure on its bottom puts it, and tilts with the surface's slope.

Statics of the linear process: heave ``zeta = eta_d`` (``rho_w g A zeta = rho_w g A eta_d``);
slope along a principal axis ``s_k = rho_w g J_k grad_k eta_d / C_k``, ``C_k = rho_w g (J_k -
A d (h - d) / 2)``, so on a square (``J_1 = J_2 = J``) the element's surface slope is the
water's times ``J / (J - A d (h - d) / 2)``, in the water's direction. Critically damped
(ratio 1) the step response has ``(1 + w t) e^{-w t}`` left: below 1e-9 after 60 s for the
block's ``w`` = 1.7 rad/s; the test allows 1e-6 of the applied head.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core import SceneError
from siku_core.geometry.quat import qmul
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_io.coupling.bmi import SikuBmi
from siku_plugins.floating.kernels import centres_and_frames

RHO_W, G, RHO_I, SIZE, H = 1026.0, 9.81, 910.0, 10.0, 1.0
M_DEG = 1.0 / 111194.92664455873
LX, LY = 20.0, 10.0     # the tilted block of the last test
SCENE = f"""title = "floating block, coupled"
[time]
duration = 120.0
dt = 0.05
[materials.ice]
density = {RHO_I}
[elements]
thickness = {H}
[[elements.pack]]
lon = [{-SIZE / 2 * M_DEG}, {SIZE / 2 * M_DEG}]
lat = [{-SIZE / 2 * M_DEG}, {SIZE / 2 * M_DEG}]
nx = 1
ny = 1
[[forcing]]
source = "exchange"
params = {{ drag = false, slope = false }}
[coupling.grid]
kind = "lonlat"
lon = [-0.025, 0.025]
lat = [-0.025, 0.025]
resolution = 0.01
[[process]]
name = "floating"
params = {{ rho_water = {RHO_W}, g = {G}, wave = "exchange", damping_ratio = 1.0, \
tilt_damping_ratio = 1.0 }}
"""


def _bmi(tmp_path, text):
    p = tmp_path / "coupled.toml"
    p.write_text(text)
    b = SikuBmi()
    b.initialize(str(p))
    return b


@pytest.fixture
def bmi(tmp_path):
    p = tmp_path / "coupled.toml"
    p.write_text(SCENE)
    b = SikuBmi()
    b.initialize(str(p))
    yield b
    b.finalize()


def _cells(bmi):
    shape = np.zeros(2, dtype=int)
    bmi.get_grid_shape(0, shape)
    lon = np.zeros(shape[1])
    bmi.get_grid_x(0, lon)
    return shape, lon


def test_the_block_settles_at_the_coupled_elevation(bmi):
    shape, _ = _cells(bmi)
    bmi.set_value("sea_water_surface__elevation", np.full(shape.prod(), 0.2))
    bmi.update_until(60.0)
    f = bmi.sim.context.fields
    assert f["heave"][0] == pytest.approx(0.2, abs=0.2e-6)
    assert abs(f["roll"][0]) < 1e-9 and abs(f["pitch"][0]) < 1e-9


def test_the_pressure_once_given_replaces_the_elevation(bmi):
    shape, _ = _cells(bmi)
    bmi.set_value("sea_water_surface__elevation", np.full(shape.prod(), 0.3))
    bmi.update_until(5.0)
    p = 500.0
    bmi.set_value("sea_ice_bottom_surface__dynamic_pressure", np.full(shape.prod(), p))
    bmi.update_until(65.0)
    head = p / (RHO_W * G)
    assert bmi.sim.context.fields["heave"][0] == pytest.approx(head, abs=head * 1e-6)


@pytest.mark.parametrize("turn,beta", [(0.0, 0.0), (30.0, 0.0), (0.0, 25.0), (-40.0, 70.0)])
def test_the_block_tilts_with_the_coupled_surface(tmp_path, turn, beta):
    """A plane rising with slope 1e-4 towards 35° north of east (central differences are
    exact on it) under a
    20 m × 10 m block whose long side is at ``beta`` degrees from its local x axis, itself
    turned ``turn`` degrees (the element's frame): the slope along each principal axis ``u_k``
    is the water's there times ``kappa_k = J_k / (J_k - A d (h - d) / 2)``, so the block
    tilts towards the water's slope but, unless aligned with it, not along it."""
    b = np.radians(beta)
    corners = [(sx * LX / 2, sy * LY / 2) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    verts = [[float((x * np.cos(b) - y * np.sin(b)) * M_DEG),
              float((x * np.sin(b) + y * np.cos(b)) * M_DEG)] for x, y in corners]
    head, rest = SCENE.split("[[elements.pack]]")
    text = head + f"[[elements.polygon]]\nvertices = {verts}\n" + rest[rest.index("[[forcing]]"):]
    bmi = _bmi(tmp_path, text)
    try:
        st = bmi.sim.state
        a = np.radians(turn) / 2
        st.q[0] = qmul(st.q[0].copy(), np.array([np.cos(a), 0.0, 0.0, np.sin(a)]))
        _, _, e0, e1 = centres_and_frames(st.q)
        assert abs(e1[0]) == pytest.approx(abs(np.sin(np.radians(turn))), abs=1e-9)
        shape, lon = _cells(bmi)
        s = 1e-4
        R = bmi.sim.radius
        lat = np.zeros(shape[0])
        bmi.get_grid_y(0, lat)
        g = s * np.array([np.cos(np.radians(35.0)), np.sin(np.radians(35.0))])
        x = np.radians(lon)[None, :] * R                    # east of 0°E [m]
        y = np.radians(lat)[:, None] * R                    # north of the equator [m]
        bmi.set_value("sea_water_surface__elevation", (g[0] * x + g[1] * y).ravel())
        bmi.update_until(60.0)
        f = bmi.sim.context.fields
        lat_c, lon_c, e0, e1 = centres_and_frames(st.q)
        e0, e1 = e0[0], e1[0]

        def world(v):      # a local vector (x, y) in (east, north)
            return np.array([v[0] * e0 + v[1] * e1, -v[0] * e1 + v[1] * e0])

        sx, sy = -f["pitch"][0], f["roll"][0]          # slopes along the local x, y
        tilt = world((sx, sy))
        d = H * RHO_I / RHO_W
        A = LX * LY
        JL, JS = LY * LX**3 / 12, LX * LY**3 / 12
        kL, kS = (J / (J - A * d * (H - d) / 2) for J in (JL, JS))
        uL, uS = world((np.cos(b), np.sin(b))), world((-np.sin(b), np.cos(b)))
        want = kL * (g @ uL) * uL + kS * (g @ uS) * uS
        np.testing.assert_allclose(tilt, want, rtol=1e-4, atol=1e-6 * s)
        # the heave is the mean elevation under the block: the plane's value at its centre
        assert f["heave"][0] == pytest.approx(R * (g[0] * lon_c[0] + g[1] * lat_c[0]),
                                              abs=1e-6 * s * LX)
    finally:
        bmi.finalize()


def test_exchange_wave_needs_the_exchange_source():
    head, rest = SCENE.split("[[forcing]]")
    text = head + "[[process]]" + rest.split("[[process]]")[1]
    with pytest.raises(SceneError, match="wave = 'exchange' needs a \\[\\[forcing\\]\\]"):
        Simulation(scene_from_text(text, "<coupled>"), out=False, progress=False)
