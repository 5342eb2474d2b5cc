"""Added mass, radiation damping and wave excitation of a floating prism from capytaine (the
linear potential-flow boundary element code; the optional extra ``siku[hydro]``), cached.

The immersed part of an element's prism (its polygon, in its principal axes, from the draft
``-d`` up to the water line) is meshed here (:func:`prism_mesh`: the bottom in fans of
quadrilaterals from the centroid, each wall in a grid of quadrilaterals, panels no larger than
``mesh_size``), made a ``capytaine.FloatingBody`` with the six rigid-body degrees of freedom
about the centre of mass ``(0, 0, h/2 - d)``, and solved with ``capytaine.BEMSolver`` for
``RadiationProblem``s (infinite depth, the scene's ``rho_w`` and ``g``). For each mode the
coefficients are taken at the mode's natural frequency, found by the fixed point ``omega =
sqrt(C / (M + A(omega)))`` from ``A = 0`` until omega changes by less than :data:`OMEGA_TOL`
(A depends little on omega: a few solves), or at a given frequency.
The slope along principal axis 1 is capytaine's ``Pitch`` (rotation about the y axis), the
slope along axis 2 its ``Roll``.

Cache: one JSON file per shape in the cache folder (``hydro_cache``; by default the user cache
``siku/hydro``, ``siku_core.contact.kernel_cache.user_cache_dir``), named by the SHA-256 of what the
result depends on (vertices to 1 mm, draft and thickness to 1 µm, densities, ``g``, panel size,
frequencies, masses and stiffnesses), marked as siku's. A file of that name that siku did not
write is never replaced; a missing folder named by the scene is an error.
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

from siku_core.errors import SceneError

#: most fixed-point solves for a mode's natural frequency, and their tolerance (relative
#: change of omega between two solves)
ITERATIONS = 12
OMEGA_TOL = 1e-6
#: the mark a cache file carries
MARK = "siku floating hydro cache"


def capytaine_module(where: str):
    try:
        import capytaine as cpt
    except ImportError:
        raise SceneError(f"{where}: coefficients = 'capytaine' needs capytaine, the optional "
                         "extra siku[hydro] (pip install 'siku[hydro]'); or give the "
                         "coefficients in the scene") from None
    import logging

    logging.getLogger("capytaine").setLevel(logging.ERROR)
    return cpt


def prism_mesh(poly: np.ndarray, draft: float, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(V, 3)`` and quadrilateral faces ``(F, 4)`` of the immersed part of the prism
    of ``poly`` (counter-clockwise ``(k, 2)`` about its centroid, [m]) from ``z = -draft`` to 0,
    normals out of the body, panels at most about ``size`` [m] (a triangle repeats its last
    vertex)."""
    verts: list[tuple[float, float, float]] = []
    faces: list[list[int]] = []

    def vid(p):
        verts.append((float(p[0]), float(p[1]), float(p[2])))
        return len(verts) - 1

    k = len(poly)
    r = float(np.max(np.hypot(poly[:, 0], poly[:, 1])))
    nr = max(1, math.ceil(r / size - 1e-9))
    nz = max(1, math.ceil(draft / size - 1e-9))
    z0 = -draft
    for e in range(k):
        a, b = poly[e], poly[(e + 1) % k]
        na = max(1, math.ceil(float(np.hypot(*(b - a))) / size - 1e-9))
        # bottom: grid (i radial, j along the edge) of the fan triangle (0, a, b)
        grid = [[vid((0.0, 0.0, z0))] * (na + 1)]
        for i in range(1, nr + 1):
            row = []
            for j in range(na + 1):
                p = (i / nr) * (a + (j / na) * (b - a))
                row.append(vid((p[0], p[1], z0)))
            grid.append(row)
        for i in range(nr):
            for j in range(na):
                q = [grid[i][j], grid[i + 1][j], grid[i + 1][j + 1], grid[i][j + 1]]
                if i == 0:
                    q = [q[0], q[1], q[2], q[2]]
                faces.append(q[::-1] if i else [q[0], q[2], q[1], q[1]])
        # the wall below edge (a, b): outward normal (dy, -dx)
        wall = [[vid((*(a + (j / na) * (b - a)), z0 + (m / nz) * draft)) for j in range(na + 1)]
                for m in range(nz + 1)]
        for m in range(nz):
            for j in range(na):
                faces.append([wall[m][j], wall[m][j + 1], wall[m + 1][j + 1], wall[m + 1][j]])
    return np.array(verts), np.array(faces, dtype=np.int64)


def body(poly, draft, thickness, size, where="capytaine"):
    """The ``capytaine.FloatingBody`` of the prism (module docstring)."""
    cpt = capytaine_module(where)
    v, f = prism_mesh(np.asarray(poly, dtype=float), float(draft), float(size))
    zg = thickness / 2.0 - draft
    mesh = cpt.Mesh(vertices=v, faces=f, name="element")
    return cpt.FloatingBody(mesh=mesh, dofs=cpt.rigid_body_dofs(rotation_center=(0, 0, zg)),
                            center_of_mass=(0, 0, zg))


def radiation(bod, dof: str, omega: float, rho: float, g: float, where="capytaine"):
    """``(A [kg or kg m²], B [kg/s or kg m²/s])`` of ``dof`` at ``omega`` [rad/s]."""
    cpt = capytaine_module(where)
    pb = cpt.RadiationProblem(body=bod, radiating_dof=dof, omega=float(omega), rho=rho, g=g,
                              water_depth=np.inf)
    r = cpt.BEMSolver().solve(pb)
    return float(r.added_mass[dof]), float(r.radiation_damping[dof])


def excitation(bod, omega: float, rho: float, g: float, direction: float = 0.0,
               where="capytaine") -> dict[str, tuple[complex, complex]]:
    """``{dof: (Froude–Krylov, diffraction)}`` complex force amplitudes [N or N m per m of
    wave amplitude] of a wave travelling along ``direction`` [rad from x], phase zero at the
    origin, time factor ``e^{-i omega t}``."""
    cpt = capytaine_module(where)
    pb = cpt.DiffractionProblem(body=bod, wave_direction=direction, omega=float(omega),
                                rho=rho, g=g, water_depth=np.inf)
    fk = cpt.bem.airy_waves.froude_krylov_force(pb)
    r = cpt.BEMSolver().solve(pb)
    return {k: (complex(fk[k]), complex(r.forces[k])) for k in r.forces}


def mode_coefficients(bod, dof, M, C, rho, g, omega=None, where="capytaine"):
    """``(A, B, omega)`` of ``dof`` at ``omega`` or, when ``None``, at the natural frequency
    (fixed point of ``sqrt(C / (M + A))`` to :data:`OMEGA_TOL`)."""
    if omega is not None:
        return (*radiation(bod, dof, omega, rho, g, where), float(omega))
    w = math.sqrt(C / M)
    for _ in range(ITERATIONS):
        A, B = radiation(bod, dof, w, rho, g, where)
        new = math.sqrt(C / (M + A))
        if abs(new - w) <= OMEGA_TOL * w:
            return A, B, w
        w = new
    raise SceneError(f"{where}: the natural frequency of {dof} did not settle in "
                     f"{ITERATIONS} capytaine solves")


def hydro_cache_dir(cache: str, base: Path, where: str) -> Path:
    if not cache:
        from siku_core.contact.kernel_cache import user_cache_dir

        d = user_cache_dir("hydro")
        d.mkdir(parents=True, exist_ok=True)
        return d
    d = Path(cache)
    if not d.is_absolute():
        d = base / d
    if not d.is_dir():
        raise SceneError(f"{where}: hydro_cache = '{cache}': no such folder ({d}); create it "
                         "or leave hydro_cache empty for the user cache")
    return d


def cached_value(cache_dir: Path, prefix: str, key: dict, compute, where: str):
    """The value cached under ``key`` (module docstring), or ``compute()`` written there."""
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]
    path = cache_dir / f"{prefix}-{digest}.json"
    if path.exists():
        try:
            data = json.loads(path.read_text())
            ours = isinstance(data, dict) and data.get("mark") == MARK
        except (OSError, ValueError, UnicodeDecodeError):
            ours = False
        if not ours:
            raise SceneError(f"{where}: {path} exists and is not a cache file siku wrote; "
                             "move it or choose another hydro_cache")
        if data.get("key") == key:
            return data["values"]
    out = compute()
    try:
        path.write_text(json.dumps({"mark": MARK, "key": key, "values": out}))
    except OSError as exc:
        import warnings

        warnings.warn(f"{path}: cannot write capytaine's cache ({exc})", stacklevel=2)
    return out


def shape_key(poly, h, d, rho, g, size) -> dict:
    return {"poly": np.round(np.asarray(poly), 3).tolist(), "draft": round(float(d), 6),
            "thickness": round(float(h), 6), "rho": rho, "g": g, "size": round(size, 6)}


def shape_coefficients(poly, h, d, M, C, rho, g, size, omega, cache_dir: Path, where):
    """``{"heave"|"slope1"|"slope2": (A, B, omega)}`` for one shape, from the cache or
    computed and cached (module docstring). ``M, C``: the three modes' masses and
    stiffnesses without added mass; ``omega``: a frequency or ``None`` (natural)."""
    key = {**shape_key(poly, h, d, rho, g, size), "omega": omega,
           "M": [float(f"{x:.9g}") for x in M], "C": [float(f"{x:.9g}") for x in C],
           "iterations": ITERATIONS, "tol": OMEGA_TOL}

    def compute():
        bod = body(poly, d, h, size, where)
        return {mode: mode_coefficients(bod, dof, m, c, rho, g, omega, where)
                for mode, dof, m, c in (("heave", "Heave", M[0], C[0]),
                                        ("slope1", "Pitch", M[1], C[1]),
                                        ("slope2", "Roll", M[2], C[2]))}

    return {k: tuple(v) for k, v in cached_value(cache_dir, "hydro", key, compute, where).items()}


def shape_excitation(poly, h, d, rho, g, size, omega, beta, depth, cache_dir, where):
    """Capytaine's Froude–Krylov plus diffraction excitation of one shape by a unit wave of
    ``omega`` [rad/s] travelling at ``beta`` [rad] from principal axis 1, as the model's
    modes: ``{"heave": N/m, "slope1": -Pitch, "slope2": Roll [N m/m]}``, complex, cached."""
    key = {**shape_key(poly, h, d, rho, g, size), "omega": float(omega),
           "beta": round(float(beta), 9), "depth": None if math.isinf(depth) else depth}

    def compute():
        cpt = capytaine_module(where)
        bod = body(poly, d, h, size, where)
        pb = cpt.DiffractionProblem(body=bod, wave_direction=float(beta), omega=float(omega),
                                    rho=rho, g=g, water_depth=depth)
        fk = cpt.bem.airy_waves.froude_krylov_force(pb)
        r = cpt.BEMSolver().solve(pb)
        tot = {k: complex(fk[k]) + complex(r.forces[k]) for k in ("Heave", "Pitch", "Roll")}
        return {"heave": [tot["Heave"].real, tot["Heave"].imag],
                "slope1": [-tot["Pitch"].real, -tot["Pitch"].imag],
                "slope2": [tot["Roll"].real, tot["Roll"].imag]}

    out = cached_value(cache_dir, "hydro-exc", key, compute, where)
    return {k: complex(*v) for k, v in out.items()}


#: most (shape, wave component) pairs the diffraction load is computed for
MAX_DIFFRACTION = 64


def diffraction_factors(bodies, points, fld, p, ctx, rho, g, where) -> np.ndarray:
    """``kap (n, M, 3, 2)``: per free element of ``bodies`` (``kernels.FloatingBodies``, its
    quadrature ``points``, ``kernels.FloatingPoints``), component of the wave field ``fld`` and
    mode, capytaine's excitation over the model's Froude–Krylov integral (real, imaginary), at
    the element's heading at the start (``siku_plugins.floating.kernels.excite``); ``p``: the
    process's parameters. A mode the wave does not load (an integral below 1e-9 of ``rho g A
    sqrt(A)``) keeps the factor 1."""
    from .kernels import attenuation, centres_and_frames

    st = ctx.state
    _, _, e0, e1 = centres_and_frames(st.q)
    cache_dir = hydro_cache_dir(p["hydro_cache"], ctx.scene.base_dir, where)
    nm = len(fld.amp)
    kap = np.zeros((st.n, nm, 3, 2))
    kap[..., 0] = 1.0
    done: dict = {}
    for i in np.flatnonzero(bodies.free):
        c, s = math.cos(bodies.phi[i]), math.sin(bodies.phi[i])
        poly = st.polygon(i) @ np.array([[c, -s], [s, c]])
        width = 2 * float(np.min(np.abs(poly).max(axis=0)))
        sz = p["mesh_size"] if p["mesh_size"] > 0 else width / 16.0
        lo, hi = points.qoff[i], points.qoff[i + 1]
        u, v, w = points.qu[lo:hi], points.qv[lo:hi], points.qw[lo:hi]
        for j in range(nm):
            ka = fld.kx[j] * e0[i] - fld.ky[j] * e1[i]   # wavenumber in local axes
            kb = fld.kx[j] * e1[i] + fld.ky[j] * e0[i]
            ku, kv = ka * c + kb * s, -ka * s + kb * c
            beta = math.atan2(kv, ku)
            key = (tuple(np.round(poly, 3).ravel()), round(bodies.h[i], 6),
                   round(bodies.draft[i], 6), float(fld.omega[j]), round(beta, 9))
            if key not in done:
                if len(done) >= MAX_DIFFRACTION:
                    raise SceneError(f"{where}: diffraction = true needs capytaine for more "
                                     f"than {MAX_DIFFRACTION} (shape, wave component) pairs; "
                                     "use it with monochromatic waves and few shapes")
                done[key] = shape_excitation(poly, bodies.h[i], bodies.draft[i], rho, g, sz,
                                             fld.omega[j], beta, float(fld.h), cache_dir,
                                             where)
            tot = done[key]
            e = np.exp(1j * (ku * u + kv * v))
            att = attenuation(fld.k[j], bodies.draft[i], float(fld.h))
            small = 1e-9 * rho * g * bodies.area[i] ** 1.5
            for mode, lever in enumerate((np.ones_like(u), u, v)):
                model = rho * g * att * np.sum(w * lever * e)
                if abs(model) > small:
                    q = tot[("heave", "slope1", "slope2")[mode]] / model
                    kap[i, j, mode] = (q.real, q.imag)
    return kap


def shape_of(st, i, phi, h, d) -> tuple:
    """The key of element ``i``'s shape: its polygon in its principal axes to 1 mm, thickness
    and draft to 1 µm (one capytaine computation per key)."""
    c, s = math.cos(phi[i]), math.sin(phi[i])
    poly = st.polygon(i) @ np.array([[c, -s], [s, c]])
    return (tuple(np.round(poly, 3).ravel()), round(h[i], 6), round(d[i], 6))


def distinct_shapes(st, free, phi, h, d) -> int:
    """How many distinct shapes (:func:`shape_of`) the free elements have."""
    return len({shape_of(st, i, phi, h, d) for i in np.flatnonzero(free)})


def element_coefficients(st, free, phi, h, d, m, I1, I2, C3, C1, C2, rho, g, cache, size,
                         omega, base, where):
    """Per element ``(A33, B33, A1, B1, A2, B2)`` arrays for the free elements (zero for the
    others), one capytaine computation per distinct shape (``shape_coefficients``)."""
    n = st.n
    out = [np.zeros(n) for _ in range(6)]
    cache_dir = hydro_cache_dir(cache, base, where)
    capytaine_module(where)
    done: dict[tuple, dict] = {}
    for i in np.flatnonzero(free):
        c, s = math.cos(phi[i]), math.sin(phi[i])
        poly = st.polygon(i) @ np.array([[c, -s], [s, c]])  # principal coordinates
        width = 2 * float(np.min(np.abs(poly).max(axis=0)))
        sz = size if size > 0 else width / 16.0
        M = (m[i], I1[i], I2[i])
        C = (C3[i], C1[i], C2[i])
        k = shape_of(st, i, phi, h, d)
        if k not in done:
            try:
                done[k] = shape_coefficients(poly, h[i], d[i], M, C, rho, g, sz, omega,
                                             cache_dir, where)
            except SceneError:
                raise
            except Exception as exc:  # noqa: BLE001 - capytaine's own failures, one line
                raise SceneError(f"{where}: capytaine could not solve element {i}'s prism "
                                 f"({type(exc).__name__}: {exc})") from None
        r = done[k]
        for j, (mode, idx) in enumerate((("heave", 0), ("heave", 1), ("slope1", 0),
                                         ("slope1", 1), ("slope2", 0), ("slope2", 1))):
            out[j][i] = r[mode][idx]
    return tuple(out)
