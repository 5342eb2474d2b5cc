"""Build the element state from a scene's ``[elements]`` table."""
from __future__ import annotations

import numpy as np

from .errors import GeometryError
from .geometry.polygon import element_from_lonlat
from .packs import rect_pack
from .scene import Scene
from .state import FLAG_NAMES, ElementState, STATIC, STEADY
from .geometry.quat import east_north_local


def build_elements(scene: Scene) -> ElementState:
    """Elements of a scene, in the order: polygons, then packs (column by column), then the
    cells of ``[elements.mesh]`` (``siku_io.mesh``, imported only here; coast and landfast
    cells are static)."""
    cfg = scene.cfg
    el = cfg.elements
    R = cfg.planet.radius
    mats = list(cfg.materials)
    items = []  # (lonlat, flag, velocity EN, spin, thickness, material, label)
    for k, p in enumerate(el.polygon):
        items.append(
            (np.array(p.vertices), p.flag, p.velocity, p.spin, p.thickness or el.thickness,
             p.material or el.material, f"{scene.label} [elements.polygon[{k}]]")
        )
    for k, pk in enumerate(el.pack):
        seed = cfg.run.seed if pk.seed is None else pk.seed
        for cell in rect_pack(pk.lon, pk.lat, pk.nx, pk.ny, pk.gap, pk.jitter, seed):
            flag, vel = pk.flag, pk.velocity
            if cell.i == 0 and pk.left is not None:
                flag, vel = pk.left, pk.left_velocity
            elif cell.i == pk.nx - 1 and pk.right is not None:
                flag, vel = pk.right, pk.right_velocity
            items.append(
                (cell.lonlat, flag, vel, pk.spin, pk.thickness or el.thickness,
                 pk.material or el.material,
                 f"{scene.label} [elements.pack[{k}]] cell (i={cell.i}, j={cell.j})")
            )
    if el.mesh is not None:
        from siku_io.mesh import ICE, KIND_NAMES, mesh_for_scene

        mc = el.mesh
        mesh, _ = mesh_for_scene(scene)
        for k in range(mesh.n):
            ice = mesh.kind[k] == ICE
            items.append(
                (mesh.cell(k), mc.flag if ice else "static", mc.velocity if ice else [0.0, 0.0],
                 mc.spin if ice else 0.0, mc.thickness or el.thickness, mc.material or el.material,
                 (f"{scene.label} [elements.mesh] cell {k} ({KIND_NAMES[mesh.kind[k]]}, seed "
                  f"{mesh.seeds[k, 0]:.4f}, {mesh.seeds[k, 1]:.4f})"))
            )
    n = len(items)
    q = np.empty((n, 4))
    V = np.zeros((n, 2))
    w = np.zeros(n)
    area = np.empty(n)
    J = np.empty(n)
    thick = np.empty(n)
    radius = np.empty(n)
    flags = np.empty(n, dtype=np.int8)
    material = np.empty(n, dtype=np.int32)
    polys = []
    for i, (ll, flag, vel, spin, h, mat, label) in enumerate(items):
        try:
            qi, loc, a, j = element_from_lonlat(ll, R, label)
        except GeometryError as exc:
            raise GeometryError(f"element {i}: {exc}") from None
        q[i] = qi
        ex, ey, nx_, ny_ = east_north_local(qi)
        V[i, 0] = vel[0] * ex + vel[1] * nx_
        V[i, 1] = vel[0] * ey + vel[1] * ny_
        w[i] = spin
        area[i] = a
        J[i] = j
        thick[i] = h
        radius[i] = np.sqrt((loc**2).sum(axis=1)).max()
        flags[i] = FLAG_NAMES[flag]
        material[i] = mats.index(mat)
        polys.append(loc)
    rho = np.array([cfg.materials[mats[k]].density for k in material]) if n else np.zeros(0)
    m = rho * thick * area
    inertia = rho * thick * J
    static = flags == STATIC
    V[static] = 0.0
    w[static] = 0.0
    offsets = np.zeros(n + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(p) for p in polys])
    verts = np.concatenate(polys) if polys else np.zeros((0, 2))
    _ = STEADY
    return ElementState(
        q=q, V=V, w=w, m=m, I=inertia, area=area, thickness=thick, radius=radius, flags=flags,
        material=material, vert_offsets=offsets, verts=verts,
    )
