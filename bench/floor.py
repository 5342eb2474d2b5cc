"""The planar C floor (``bench/floor.c``): what the bonded-pack step costs in plain C.

:func:`measure` writes the geometry of a running benchmark scene (element centres and
orientations projected onto the plane ``x = R lon, y = R lat``, the polygons, velocities and
masses, the joints with their stiffness and damping, the current candidate pairs and which of
them the engine clipped at its last step: the probe clips those too) to a file,
compiles the probe once per process with the system C compiler (``cc -O2``, into a temporary
directory; nothing is kept) and runs it on one thread. Returns the best and median ns per
element-step over the probe's repetitions, or ``None`` where no C compiler is found.

The probe is not siku and is never imported by it: the benchmark uses it only to print, next
to each single-thread rate, how far the engine is from the same work written plainly.
"""
from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
_BUILT: list[Path] = []


def _compiler() -> str | None:
    for cc in ("cc", "gcc", "clang"):
        if shutil.which(cc):
            return cc
    return None


def build() -> Path | None:
    """The compiled probe (built once per process), or ``None`` without a C compiler."""
    if _BUILT:
        return _BUILT[0]
    cc = _compiler()
    if cc is None:
        return None
    where = Path(tempfile.mkdtemp(prefix="siku-floor-"))
    exe = where / "floor"
    subprocess.run([cc, "-O2", "-o", str(exe), str(HERE / "floor.c"), "-lm"], check=True)
    _BUILT.append(exe)
    return exe


def dump(sim, path: Path) -> None:
    """Write the planar version of ``sim``'s current state and contacts for the probe."""
    from siku_core.geometry.quat import east_north_row, latlon_of
    from siku_core.state import FREE

    st, R = sim.state, sim.radius
    n = st.n
    lat, lon = latlon_of(st.q)
    th = np.empty(n)
    vx = np.empty(n)
    vy = np.empty(n)
    for i in range(n):
        ex, ey, nx, ny = east_north_row(st.q, i)
        th[i] = math.atan2(nx, ex)  # the local x axis, counter-clockwise from east
        vx[i] = st.V[i, 0] * ex + st.V[i, 1] * ey
        vy[i] = st.V[i, 0] * nx + st.V[i, 1] * ny
    cm = sim.contacts
    mats = list(sim.scene.cfg.materials.values())
    E = mats[0].youngs_modulus
    h = float(np.mean(st.thickness))
    kc = E * h / (2.0 * float(np.mean(st.radius)))  # eq. 9 for equal elements
    wind = (10.0, 0.0)
    rhoc = 1.3 * 1.2e-3  # air density [kg/m³] times drag coefficient
    if cm is not None and cm.law.uses_joints and cm.n_joints:
        ji, jj = cm.ji, cm.jj
        ei, ej = cm.ends_i.reshape(-1, 4), cm.ends_j.reshape(-1, 4)
        K, width = cm.jK, cm.width
        zeta = np.full(len(ji), float(cm.law.p.get("joint_damping_ratio", 0.1)))
    else:
        ji = jj = np.zeros(0, np.int64)
        ei = ej = np.zeros((0, 4))
        K = width = zeta = np.zeros(0)
    pairs = cm.pairs if cm is not None else np.zeros((0, 2), np.int64)
    flags = np.where(st.flags == FREE, 0.0, np.where(st.flags == 1, 1.0, 2.0))
    with open(path, "wb") as f:
        np.array([n, len(st.verts), len(ji), len(pairs)], np.int64).tofile(f)
        np.array([sim.dt, kc, rhoc, *wind], float).tofile(f)
        for a in (R * lon, R * lat, th, vx, vy, st.w, st.m, st.I, st.area, flags):
            np.ascontiguousarray(a, dtype=float).tofile(f)
        np.ascontiguousarray(st.vert_offsets, np.int64).tofile(f)
        np.ascontiguousarray(st.verts, float).tofile(f)
        for a in (ji, jj):
            np.ascontiguousarray(a, np.int64).tofile(f)
        for a in (ei, ej, K, width, zeta):
            np.ascontiguousarray(a, float).tofile(f)
        np.ascontiguousarray(pairs, np.int64).tofile(f)
        clipped = ((cm.pair_active == 1)
                   if cm is not None and len(cm.pair_active) == len(pairs)
                   else np.zeros(len(pairs), bool))
        clipped.astype(float).tofile(f)


def measure(sim, steps: int = 20, repeat: int = 5) -> dict | None:
    """Best and median ns per element-step of the probe on ``sim``'s current geometry, and
    the pairs it found overlapping; ``None`` without a C compiler."""
    exe = build()
    if exe is None:
        return None
    with tempfile.TemporaryDirectory(prefix="siku-floor-") as tmp:
        path = Path(tmp) / "scene.bin"
        dump(sim, path)
        out = subprocess.run([str(exe), str(path), str(steps), str(repeat)], check=True,
                             capture_output=True, text=True).stdout.split()
    return {"best_ns": float(out[0]), "median_ns": float(out[1]), "overlapping": int(out[2]),
            "clipped_as_engine": int(out[3])}
