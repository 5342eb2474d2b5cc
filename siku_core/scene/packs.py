"""Rectangular and jittered packs of quadrilateral elements over a lon/lat box."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PackCell:
    """One element of a pack: ``[lon, lat]`` vertices (degrees, CCW) and its grid indices."""

    lonlat: np.ndarray
    i: int
    j: int


def rect_pack(
    lon: tuple[float, float],
    lat: tuple[float, float],
    nx: int,
    ny: int,
    gap: float = 0.0,
    jitter: float = 0.0,
    seed: int = 0,
) -> list[PackCell]:
    """``nx × ny`` cells over ``lon × lat`` (degrees; ``lon[1] < lon[0]`` wraps eastward).

    ``jitter`` moves every interior grid node by up to that share of the cell size (seeded), so
    neighbours still share edges; ``gap`` shrinks each cell about its centre by that share,
    leaving open water between elements (a drifting fleet). Cells are ordered column by column
    (``i`` west→east, then ``j`` south→north).
    """
    lon0, lon1 = float(lon[0]), float(lon[1])
    if lon1 <= lon0:
        lon1 += 360.0
    lat0, lat1 = float(lat[0]), float(lat[1])
    xs = np.linspace(lon0, lon1, nx + 1)
    ys = np.linspace(lat0, lat1, ny + 1)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    if jitter > 0:
        rng = np.random.default_rng(seed)
        dx = (lon1 - lon0) / nx
        dy = (lat1 - lat0) / ny
        jx = rng.uniform(-jitter, jitter, gx.shape) * dx
        jy = rng.uniform(-jitter, jitter, gy.shape) * dy
        jx[[0, -1], :] = 0.0  # keep the outline straight
        jy[:, [0, -1]] = 0.0
        gx = gx + jx
        gy = gy + jy
    cells = []
    for i in range(nx):
        for j in range(ny):
            v = np.array(
                [
                    [gx[i, j], gy[i, j]],
                    [gx[i + 1, j], gy[i + 1, j]],
                    [gx[i + 1, j + 1], gy[i + 1, j + 1]],
                    [gx[i, j + 1], gy[i, j + 1]],
                ]
            )
            if gap > 0:
                c = v.mean(axis=0)
                v = c + (1.0 - gap) * (v - c)
            v[:, 0] = (v[:, 0] + 180.0) % 360.0 - 180.0 if np.ptp(v[:, 0]) < 180 else v[:, 0]
            cells.append(PackCell(v, i, j))
    return cells
