"""Reflection and transmission of monochromatic waves by a group of free-floating floes, from
capytaine's multi-body diffraction and radiation (the optional extra ``siku[hydro]``), cached.

Each floe is a rigid rectangular box (sides ``lx``, ``ly``, thickness ``h``, draft ``d = h
rho_i / rho_w``) free in its six rigid-body modes about its centre of mass. One capytaine
body joins them all, so the diffraction and the 6 N radiation problems include every
interaction between the floes. Deep water, incident wave of amplitude 1 m travelling along +x.

Free floating: the motions ``xi = [-omega² (M + A) - i omega B + C]^-1 F`` (mass ``M`` and
hydrostatic stiffness ``C`` of each box, analytic; ``A, B, F`` capytaine's). The scattered
wave's Kochin function is ``H = H_D + sum_j xi_j H_j`` (capytaine's ``compute_kochin``, with
the radiation potentials per unit displacement). With capytaine's Green function the scattered
elevation far away is ``A(theta) e^{ikr} / sqrt(r)``, ``A = (2 pi omega k / g) sqrt(2 / (pi
k)) e^{-i pi / 4} H``, so that in units of the incident flux per metre of crest

* the scattering width ``sigma_s = int |A|² dtheta`` (split into the backward half
  ``|theta| > pi / 2`` and the forward half), and
* the extinction width (optical theorem) ``sigma_e = -(8 pi omega / g) Re H(0)``.

A lossless group has ``sigma_e = sigma_s`` (energy conservation, checked in
``tests/test_floating_scatter.py``). Each radiation problem alone obeys ``int |A_j|² dtheta =
omega² B_jj / (rho g c_g)`` (``c_g = g / (2 omega)``) as the panels shrink (``rad_check``; on
thin floes the damping from the hull pressure converges slowly: heave of a 91 m floe at 6 s,
0.71, 0.89 and 0.94 of the far-field value with panels of 8, 4 and 2.5 m).

In a flume of width ``W`` (the floes' images in its walls neglected), the energy reflection and
transmission coefficients are ``K_r = sigma_back / W`` and ``K_t = 1 - (sigma_e -
sigma_forward) / W``, ``K_r + K_t = 1 - (sigma_e - sigma_s) / W``.

Cache: one JSON file per (floes, period, mesh) in the cache folder, named by the SHA-256 of
what the result depends on (``hydro.cached_value``, the same files and mark as the floating
process's coefficients).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from siku_plugins.floating import hydro

#: the angles of the far-field integrals (uniform, ``THETAS`` of them over 2 pi)
THETAS = 720


def _box(cpt, i, lx, ly, h, d, x, y, size):
    nx, ny = max(1, math.ceil(lx / size)), max(1, math.ceil(ly / size))
    nz = max(1, math.ceil(h / size))
    zg = h / 2.0 - d
    mesh = cpt.mesh_parallelepiped(size=(lx, ly, h), center=(x, y, zg),
                                   resolution=(nx, ny, nz), name=f"floe{i}")
    body = cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=(x, y, zg)),
                            center_of_mass=(x, y, zg), name=f"floe{i}")
    return body.immersed_part()


def box_matrices(lx, ly, h, rho_i, rho_w, g):
    """Mass and hydrostatic stiffness matrices (6 x 6, modes surge, sway, heave, roll, pitch,
    yaw about the centre of mass) of a freely floating box (module docstring)."""
    d = h * rho_i / rho_w
    m = rho_i * lx * ly * h
    M = np.diag([m, m, m, m * (ly**2 + h**2) / 12, m * (lx**2 + h**2) / 12,
                 m * (lx**2 + ly**2) / 12])
    vol = lx * ly * d
    zbg = -d / 2 - (h / 2 - d)        # centre of buoyancy below the centre of mass
    C = np.zeros((6, 6))
    C[2, 2] = rho_w * g * lx * ly
    C[3, 3] = rho_w * g * (lx * ly**3 / 12 + vol * zbg)
    C[4, 4] = rho_w * g * (ly * lx**3 / 12 + vol * zbg)
    return M, C


def solve(floes, h, period, size, rho_i=920.0, rho_w=1025.0, g=9.81, where="scatter"):
    """The far field of the floes ``[(lx, ly, x, y), ...]`` (module docstring) in waves of
    ``period`` s: ``{"sigma_back", "sigma_forward", "sigma_ext", "rad_check"}`` (widths in m;
    ``rad_check``: per radiating mode ``[int |A_j|², omega² B_jj / (rho g c_g)]``; ``rao``: the
    motions' amplitudes per mode, m and rad per m of wave)."""
    cpt = hydro.capytaine_module(where)
    omega = 2 * math.pi / period
    k = omega**2 / g
    d = h * rho_i / rho_w
    bodies = [_box(cpt, i, lx, ly, h, d, x, y, size) for i, (lx, ly, x, y) in enumerate(floes)]
    body = cpt.FloatingBody.join_bodies(*bodies, name="floes") if len(bodies) > 1 else bodies[0]
    dofs = list(body.dofs)
    n = len(dofs)
    M, C = np.zeros((n, n)), np.zeros((n, n))
    for i, (lx, ly, _, _) in enumerate(floes):
        Mi, Ci = box_matrices(lx, ly, h, rho_i, rho_w, g)
        M[6 * i:6 * i + 6, 6 * i:6 * i + 6] = Mi
        C[6 * i:6 * i + 6, 6 * i:6 * i + 6] = Ci
    solver = cpt.BEMSolver()
    kw = dict(omega=omega, rho=rho_w, g=g, water_depth=np.inf)
    diff = solver.solve(cpt.DiffractionProblem(body=body, wave_direction=0.0, **kw),
                        keep_details=True)
    fk = cpt.bem.airy_waves.froude_krylov_force(diff.problem)
    F = np.array([diff.forces[q] + fk[q] for q in dofs])
    rads = [solver.solve(cpt.RadiationProblem(body=body, radiating_dof=q, **kw),
                         keep_details=True) for q in dofs]
    A = np.array([[r.added_mass[q] for q in dofs] for r in rads]).T
    B = np.array([[r.radiation_damping[q] for q in dofs] for r in rads]).T
    xi = np.linalg.solve(-omega**2 * (M + A) - 1j * omega * B + C, F)
    theta = np.linspace(-math.pi, math.pi, THETAS, endpoint=False)
    kd = cpt.post_pro.kochin.compute_kochin
    Hj = np.array([kd(r, theta) for r in rads])
    H = kd(diff, theta) + xi @ Hj
    fac = (2 * math.pi * omega * k / g) * math.sqrt(2 / (math.pi * k))
    dth = 2 * math.pi / THETAS
    back = np.abs(theta) > math.pi / 2
    a2 = np.abs(fac * H) ** 2
    cg = g / (2 * omega)
    zero = np.array([0.0])
    H0 = kd(diff, zero)[0] + xi @ np.array([kd(r, zero)[0] for r in rads])
    rad = [[float(np.sum(np.abs(fac * Hj[j]) ** 2) * dth),
            float(omega**2 * B[j, j] / (rho_w * g * cg))] for j in range(n)]
    return {"sigma_back": float(np.sum(a2[back]) * dth),
            "sigma_forward": float(np.sum(a2[~back]) * dth),
            "sigma_ext": float(-(8 * math.pi * omega / g) * H0.real),
            "rad_check": rad, "rao": [float(abs(x)) for x in xi]}


def coefficients(floes, h, period, width, size, cache="", base: Path | None = None,
                 rho_i=920.0, rho_w=1025.0, g=9.81, where="scatter"):
    """``(K_r, K_t, far)`` of the floes in a flume of ``width`` m (module docstring), ``far``
    from ``solve``, cached."""
    cache_dir = hydro.hydro_cache_dir(cache, base or Path.cwd(), where)
    key = {"what": "scatter", "floes": [[float(v) for v in f] for f in floes], "h": float(h),
           "period": float(period), "size": float(size), "rho_i": float(rho_i),
           "rho_w": float(rho_w), "g": float(g), "thetas": THETAS}
    far = hydro.cached_value(cache_dir, "scatter", key,
                        lambda: solve(floes, h, period, size, rho_i, rho_w, g, where), where)
    kr = far["sigma_back"] / width
    kt = 1.0 - (far["sigma_ext"] - far["sigma_forward"]) / width
    return kr, kt, far
