"""V3 binary collision (docs/explanation/physics.md §8, §4.3 "collision").

Two free 2 km squares of 1 m ice (E = 1 GPa, rho = 910 kg/m³) collide under law "collision".

Face-on case: both centres on the equator, faces parallel (north is the same direction in both
tangent planes there), closing at 1 m/s while the pair drifts east at 0.3 m/s. The contact is
then a linear spring-dashpot in the penetration depth ``x``: the overlap is the strip ``L x``
(``L`` = 2 km, the face), the elastic force ``K A = K L x`` with ``K = h E / (r_i + r_j)``
(eq. 9, ``r`` = 1 km less ``x/2``), and the damping a share ``z`` of critical for ``k = K L`` on
the reduced mass ``m/2``. Its restitution (exit over entry normal speed) is
``exp(-z pi / sqrt(1 - z²))``.

Energy with ``z = 0``: siku2 is symplectic Euler on the relative motion (kick with the force of
the current overlap, then drift). For a harmonic oscillator it conserves
``v² + w² x² - w² dt x v`` exactly; the contact switches on and off between steps, so entry and
exit each change ``v²`` by ``w² x (x - v dt)`` with ``|x| <= v dt``, i.e. by at most
``(w dt)² v² / 4``, with opposite signs (a 1-D model with random entry phases reaches both
ends). Hence ``|v_out² / v_in² - 1| <= (w dt)² / 4``: the kinetic energy of the relative motion
returns to within that share, a tolerance that falls as ``dt²``.

Momentum: the engine applies equal and opposite forces at the same point on the sphere, and
siku2's drift leaves the global angular momentum unchanged, so the angular momentum about the
planet centre (orbital ``R c × m v`` plus spin ``I w c``: it encodes the linear momentum of the
pair too) is conserved to round-off, checked at every step to 1e-10 relative.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import centers, qmatrix
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import contact_scene

R = 6_371_000.0
SIZE = 2000.0  # square side [m]
H, E, RHO = 1.0, 1e9, 910.0
GAP = 10.0  # open water between the faces at the start [m]
V_CLOSE = 1.0  # closing speed [m/s]
DT = 0.05  # [s]; w dt = 0.037, far below the critical w dt = 2


def face_on_scene(z: float, dt: float):
    dlon = math.degrees((SIZE + GAP) / R)
    return contact_scene(
        "collision", {"damping_ratio": z},
        elements=[{"center": (-0.5 * dlon, 0.0), "velocity": (0.8, 0.0)},
                  {"center": (0.5 * dlon, 0.0), "velocity": (-0.2, 0.0)}],
        size=SIZE, thickness=H, youngs_modulus=E, dt=dt, steps=10_000,
    )


def oblique_scene(z: float, dt: float):
    """Off-centre, oblique impact at 70°N: j is 800 m north of i's axis and both move
    obliquely, so the overlap centroid is off the line of centres and the pair starts to spin."""
    lat = 70.0
    dlon = math.degrees((SIZE + GAP) / (R * math.cos(math.radians(lat))))
    dlat = math.degrees(800.0 / R)
    return contact_scene(
        "collision", {"damping_ratio": z, "friction": 0.3},
        elements=[{"center": (20.0, lat), "velocity": (0.6, 0.1)},
                  {"center": (20.0 + dlon, lat + dlat), "velocity": (-0.4, -0.15)}],
        size=SIZE, thickness=H, youngs_modulus=E, dt=dt, steps=10_000,
    )


def angular_momentum(sim) -> np.ndarray:
    d = sim.diagnostics()
    return np.array([d["angular_momentum_x"], d["angular_momentum_y"], d["angular_momentum_z"]])


def global_velocities(sim) -> np.ndarray:
    st = sim.state
    return np.array([qmatrix(st.q[k]) @ np.array([st.V[k, 0], st.V[k, 1], 0.0])
                     for k in range(st.n)])


def normal_speed(sim) -> float:
    """Speed of j relative to i along the line from i's centre to j's [m/s] (< 0: closing)."""
    c = centers(sim.state.q)
    u = c[1] - c[0]
    u /= np.linalg.norm(u)
    v = global_velocities(sim)
    return float((v[1] - v[0]) @ u)


def collide(sim, max_steps: int = 5000) -> dict:
    """Step until the pair has touched and separated again; return what the tests need."""
    L0 = angular_momentum(sim)
    out = {"vn_in": normal_speed(sim), "ke_in": sim.diagnostics()["kinetic_energy"],
           "dL": 0.0, "contact_steps": 0}
    touched = False
    for _ in range(max_steps):
        sim.step()
        L = angular_momentum(sim)
        out["dL"] = max(out["dL"], float(np.linalg.norm(L - L0) / np.linalg.norm(L0)))
        if sim.contacts.n_overlap:
            touched = True
            out["contact_steps"] += 1
        elif touched:
            break
    else:  # pragma: no cover - setup error
        raise AssertionError("the pair did not collide and separate")
    out["vn_out"] = normal_speed(sim)
    out["ke_out"] = sim.diagnostics()["kinetic_energy"]
    out["w"] = sim.state.w.copy()
    return out


def run(scene) -> tuple[Simulation, dict]:
    sim = Simulation(scene, out=False, progress=False)
    return sim, collide(sim)


@pytest.fixture(scope="module")
def elastic():
    """Face-on, z = 0, at dt and dt/2."""
    return {dt: run(face_on_scene(0.0, dt)) for dt in (DT, DT / 2)}


def omega() -> float:
    """Angular frequency of the face-on contact at zero overlap [rad/s]."""
    K = H * E * H * E / (H * E * SIZE / 2 + H * E * SIZE / 2)  # eq. 9, r_i = r_j = 1 km
    m = RHO * H * SIZE**2
    return math.sqrt(K * SIZE / (m / 2))


def test_time_step_well_below_critical(elastic):
    sim, res = elastic[DT]
    assert DT < 0.1 * sim.critical_dt
    assert omega() * DT < 0.04
    # the contact lasts half a period pi/w: resolved by ~85 steps
    assert res["contact_steps"] == pytest.approx(math.pi / omega() / DT, rel=0.05)


@pytest.mark.parametrize("dt", [DT, DT / 2])
def test_face_on_conserves_angular_momentum(elastic, dt):
    _, res = elastic[dt]
    assert res["dL"] < 1e-10


@pytest.mark.parametrize("dt", [DT, DT / 2])
def test_elastic_energy_returns_within_dt_bound(elastic, dt):
    _, res = elastic[dt]
    # the chord between the centres leans out of the tangent planes by d/2R: cos -> 1e-8
    assert res["vn_in"] == pytest.approx(-V_CLOSE, rel=1e-7)
    m = RHO * H * SIZE**2
    ke_rel = 0.5 * (m / 2) * V_CLOSE**2  # energy of the relative motion
    # (w dt)²/4 bound derived in the module docstring; 1 % on top covers K growing with the
    # penetration (x_max / (r_i + r_j) = (v/w) / 2 km < 1e-3)
    bound = (omega() * dt) ** 2 / 4 * 1.01
    err = abs(res["ke_out"] - res["ke_in"]) / ke_rel
    assert err <= bound, f"dt = {dt}: |dKE|/KE_rel = {err:.3e} > {bound:.3e}"
    assert abs(res["vn_out"] / res["vn_in"] + 1.0) <= bound
    # no spin from a face-on impact
    assert np.abs(res["w"]).max() < 1e-12


def test_elastic_energy_error_shrinks_with_dt(elastic):
    errs = [abs(elastic[dt][1]["ke_out"] / elastic[dt][1]["ke_in"] - 1.0) for dt in (DT, DT / 2)]
    # measured 2.5e-4 then 6.3e-5: second order
    assert errs[1] < errs[0] / 3


@pytest.mark.parametrize("z", [0.1, 0.3])
def test_restitution_matches_damping_ratio(z):
    _, res = run(face_on_scene(z, DT))
    e = -res["vn_out"] / res["vn_in"]
    expected = math.exp(-z * math.pi / math.sqrt(1.0 - z * z))
    assert e == pytest.approx(expected, rel=0.02), f"z = {z}: e = {e:.5f}, expected {expected:.5f}"
    assert res["dL"] < 1e-10
    assert res["ke_out"] < res["ke_in"]


def test_oblique_off_centre_impact_spins_and_conserves_angular_momentum():
    _, res = run(oblique_scene(0.1, DT))
    assert res["dL"] < 1e-10
    # the overlap lies north of i's centre and south of j's; the normal impulse
    # J ~ m v_n (1 + e) / 2 pushes i west and j east there, so both turn counter-clockwise at
    # ~J r / I = 6 r v_n (1 + e) / (2 L²) ~ 1e-4 rad/s for a lever arm r ~ 400 m
    w = res["w"]
    assert np.all(w > 1e-5), f"spins after the impact: {w}"
    assert res["ke_out"] < res["ke_in"]  # damping and friction dissipate
