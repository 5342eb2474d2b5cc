"""Floating elements with capytaine's hydrodynamics (siku_plugins.floating.hydro, the optional
extra siku[hydro]): the prism mesh against capytaine's own box, the cache, the bouncing block of
Orzech et al. (2018) against the damped oscillator of capytaine's A33, B33 at the block's
natural frequency, and the steady heave in monochromatic waves against capytaine's response
amplitude operator (Froude–Krylov plus diffraction) at three frequencies."""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from siku_core.errors import SceneError

cpt = pytest.importorskip("capytaine")

from siku_plugins.floating import hydro  # noqa: E402

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from test_floating import G, RHO_I, RHO_W, block, peaks, run, steady_response, wave_forcing  # noqa: E402,I001

SIZE = 1.0   # capytaine's panels [m] in these tests
SQUARE = np.array([[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]])
H = 1.0
D = H * RHO_I / RHO_W


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("hydro")


def test_prism_mesh_is_capytaines_box():
    """Heave and pitch added mass and damping of the prism mesh equal those of capytaine's
    mesh_parallelepiped of the same box within 2 % (two meshes of the same body, panels of
    0.6 m: their discretisation errors are about 1 %)."""
    ours = hydro.body(SQUARE, D, H, 0.625)
    zg = H / 2 - D
    box = cpt.FloatingBody(
        mesh=cpt.mesh_parallelepiped(size=(10, 10, H), center=(0, 0, H / 2 - D),
                                     resolution=(16, 16, 2)),
        dofs=cpt.rigid_body_dofs(rotation_center=(0, 0, zg)),
        center_of_mass=(0, 0, zg)).immersed_part()
    for dof in ("Heave", "Pitch"):
        a, b = hydro.radiation(ours, dof, 1.7, RHO_W, G)
        a2, b2 = hydro.radiation(box, dof, 1.7, RHO_W, G)
        assert a == pytest.approx(a2, rel=2e-2) and b == pytest.approx(b2, rel=2e-2)


def block_scene(cache, extra="", **kw):
    return block(f'coefficients = "capytaine", hydro_cache = "{cache}", mesh_size = {SIZE}'
                 + (", " + extra if extra else ""), **kw)


def test_bouncing_block_is_capytaines_damped_oscillator(cache):
    """10 m × 10 m × 1 m released 0.2 m above its floating position: the period between
    peaks and the ratio of successive peaks are those of the oscillator of mass m + A33,
    stiffness rho_w g A and damping B33, capytaine's at the natural frequency, within 2 %."""
    sim, z = run(block_scene(cache, "initial_heave = 0.2", duration=15.0, dt=0.01))
    p = sim.processes[0]
    M, B, C = p.M3[0], p.B3[0], p.C3[0]
    wn = math.sqrt(C / M)
    zeta = B / (2 * math.sqrt(M * C))
    Td = 2 * math.pi / (wn * math.sqrt(1 - zeta**2))
    ratio = math.exp(-zeta * wn * Td)
    # capytaine's own coefficients at that frequency, not the process's
    A33, B33 = hydro.radiation(hydro.body(SQUARE, D, H, SIZE), "Heave", wn, RHO_W, G)
    assert M == pytest.approx(RHO_I * H * 100 + A33, rel=1e-4)
    assert B == pytest.approx(B33, rel=1e-4)
    t = sim.dt * np.arange(1, len(z) + 1)
    tp, zp = peaks(t, z)
    assert len(tp) >= 3
    assert np.diff(tp) == pytest.approx(np.full(len(tp) - 1, Td), rel=2e-2)
    assert zp[1:] / zp[:-1] == pytest.approx(np.full(len(zp) - 1, ratio), rel=2e-2)


def test_the_cache_is_read_and_foreign_files_are_kept(cache, monkeypatch):
    txt = block_scene(cache, "initial_heave = 0.2", duration=0.02, dt=0.01)
    run(txt, steps=1)   # computed (or already cached by the test above)

    def no_solver(*a, **k):
        raise AssertionError("capytaine called although the result is cached")

    monkeypatch.setattr(hydro, "radiation", no_solver)
    run(txt, steps=1)
    monkeypatch.undo()
    files = sorted(cache.glob("hydro-*.json"))
    assert files
    other = cache / "elsewhere"
    other.mkdir()
    for f in files:
        (other / f.name).write_text("not siku's")
    with pytest.raises(SceneError, match="not a cache file siku wrote"):
        run(block_scene(other, "initial_heave = 0.2", duration=0.02, dt=0.01), steps=1)
    assert all((other / f.name).read_text() == "not siku's" for f in files)


def test_without_capytaine_the_scene_says_so(cache, monkeypatch):
    monkeypatch.setitem(sys.modules, "capytaine", None)
    with pytest.raises(SceneError, match=r"siku\[hydro\]"):
        run(block(f'coefficients = "capytaine", hydro_cache = "{cache}", mesh_size = 3.0'),
            steps=1)


def test_a_shape_capytaine_cannot_mesh_is_one_line(tmp_path, monkeypatch):
    """capytaine refusing the element's prism mesh (its ``Mesh`` raising, as it does for a
    degenerate one) is one line naming the element, not capytaine's traceback; a fresh cache so
    that capytaine is asked."""
    def refuse(*args, **kwargs):
        raise ValueError("a panel has zero area")

    import capytaine

    monkeypatch.setattr(capytaine, "Mesh", refuse)
    with pytest.raises(SceneError, match="capytaine could not solve element 0's prism "
                                         r"\(ValueError: a panel has zero area\)"):
        run(block_scene(tmp_path, "initial_heave = 0.2", duration=0.02, dt=0.01), steps=1)


@pytest.mark.parametrize("T", [4.0, 5.0, 8.0])
def test_heave_in_waves_is_capytaines_rao(cache, T):
    """The block in a small monochromatic wave (amplitude 2 cm: within its freeboard), with
    capytaine's A33, B33 at the wave's frequency and its Froude–Krylov plus diffraction load:
    steady heave amplitude and phase equal capytaine's RAO, X = F / (C - w² (m + A33) -
    i w B33), within 2 % (phase: 0.02 rad)."""
    a = 0.02
    txt = block_scene(cache, 'frequency = "wave", diffraction = true', duration=10 * T,
                      dt=0.02, forcing=wave_forcing(a, T))
    sim, z = run(txt)
    w = 2 * math.pi / T
    bod = hydro.body(SQUARE, D, H, SIZE)
    A33, B33 = hydro.radiation(bod, "Heave", w, RHO_W, G)
    F = sum(hydro.excitation(bod, w, RHO_W, G)["Heave"])
    X = a * F / (RHO_W * G * 100 - w * w * (RHO_I * H * 100 + A33) - 1j * w * B33)
    t = sim.dt * np.arange(1, len(z) + 1)
    got = steady_response(z, t, w)
    assert abs(got) == pytest.approx(abs(X), rel=2e-2)
    assert abs(np.angle(got / X)) < 2e-2
