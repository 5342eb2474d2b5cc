"""The attenuation the ice's response implies beside the law's (``spectral`` wave field with a
``floating`` process): both defined by the energy balance ``P = 2 k rho g sum c_g E``; the
constant law's is ``C alpha`` exactly, the response's is the drag and radiated power of the
cell's elements over the flux, and both are written per element."""
from __future__ import annotations

import numpy as np
import pytest

from tests.test_spectral import build, flume_scene

RHO, G = 1025.0, 9.81


def flume(tmp_path, alpha, **params):
    path = flume_scene(tmp_path, {"attenuation": "constant",
                                  "attenuation_params": {"alpha": alpha}, **params})
    path.write_text(path.read_text() + '\n[[process]]\nname = "floating"\n')
    return build(path)


@pytest.mark.parametrize("spectrum", [{}, {"spectrum": "jonswap", "hs": 1.0, "tp": 8.0,
                                           "n_frequencies": 6, "n_directions": 1}])
def test_the_response_attenuation_is_the_ice_power_over_the_energy_flux(tmp_path, spectrum):
    alpha = 1e-4
    sim = flume(tmp_path, alpha, **spectrum)
    f = sim.forcing[0].field
    fields = sim.context.fields
    st = sim.state
    for _ in range(3):
        before = f.response_power()
        sim.step()
    # the field wrote, when the step began, the rates of the power of the step before
    k_law, k_resp = f.attenuations(before)
    c = f.element_cell
    np.testing.assert_array_equal(fields["wave_attenuation"], k_law.ravel()[c])
    np.testing.assert_array_equal(fields["wave_response_attenuation"], k_resp.ravel()[c])
    # the power: drag plus radiation damping, both reported by the process and the field
    power = f.response_power()
    assert (fields["wave_radiated_power"] > 0).all() and (f.drag_power != 0).any()
    np.testing.assert_allclose(power, f.drag_power + fields["wave_radiated_power"] * st.area,
                               rtol=1e-15)
    k_law, k_resp = f.attenuations(power)
    # constant law: every component decays at C alpha, so its flux-weighted mean is C alpha
    np.testing.assert_allclose(k_law, f.C * alpha, rtol=1e-12, atol=0)
    # the response: P per cell area over 2 rho g sum c_g E, cell by cell
    cell_power = np.zeros(f.nx * f.ny)
    np.add.at(cell_power, c, power)
    flux = 2 * RHO * G * (f.cg[:, None, None] * f.E).sum(axis=0)
    want = cell_power.reshape(f.ny, f.nx) / (f.dx * f.dy) / flux
    np.testing.assert_allclose(k_resp, want, rtol=1e-12, atol=0)
    assert (k_resp[f.C == 0] == 0).all() and (k_resp[f.C > 0] > 0).all()


def test_a_calm_cell_reports_zero_not_nan(tmp_path):
    sim = flume(tmp_path, 1e-4, start="calm")
    f = sim.forcing[0].field
    k_law, k_resp = f.attenuations(np.ones(sim.state.n))
    assert (k_law == 0).all() and (k_resp == 0).all()
