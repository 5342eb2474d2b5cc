"""Element state as a structure of arrays (float64 throughout).

Per element ``i``: quaternion ``q[i] (4)``, local surface velocity ``V[i] = (Vx, Vy)`` [m/s],
spin ``w[i]`` [rad/s], force accumulator ``F[i]`` [N] (local frame), torque ``T[i]`` [N m]
about the local vertical, mass ``m`` [kg], polar moment ``I`` [kg m²] about the centroid, area
[m²], thickness [m], bounding radius [m], ``flags`` (:data:`FREE`, :data:`STATIC`,
:data:`STEADY`, :data:`MELTED`) and ``material`` index. Polygons are ragged (CSR): element
``i`` has vertices ``verts[vert_offsets[i]:vert_offsets[i+1]]`` [m] in its local tangent plane,
counter-clockwise, centroid at the origin.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

FREE = 0
STATIC = 1
STEADY = 2
#: an element a process melted away (``siku_core.ice``): it neither moves nor touches anything
MELTED = 3
#: the kinds a scene may give an element
FLAG_NAMES = {"free": FREE, "static": STATIC, "steady": STEADY}
#: every flag code an output may hold (CF ``flag_meanings``)
FLAG_MEANINGS = {**FLAG_NAMES, "melted": MELTED}

#: arrays that change during a run (the rest is fixed geometry and material)
DYNAMIC = ("q", "V", "w")


@dataclass
class ElementState:
    """Structure-of-arrays state of ``n`` ice elements."""

    q: np.ndarray
    V: np.ndarray
    w: np.ndarray
    m: np.ndarray
    I: np.ndarray  # noqa: E741 - the physics name
    area: np.ndarray
    thickness: np.ndarray
    radius: np.ndarray
    flags: np.ndarray
    material: np.ndarray
    vert_offsets: np.ndarray
    verts: np.ndarray
    F: np.ndarray = field(default=None)  # type: ignore[assignment]
    T: np.ndarray = field(default=None)  # type: ignore[assignment]
    #: floe (bonded group made by one floe of a source) of each element, -1 for none
    floe: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        n = self.q.shape[0]
        if self.floe is None:
            self.floe = np.full(n, -1, dtype=np.int64)
        if self.F is None:
            self.F = np.zeros((n, 2))
        if self.T is None:
            self.T = np.zeros(n)

    @property
    def n(self) -> int:
        return self.q.shape[0]

    def polygon(self, i: int) -> np.ndarray:
        """Vertices ``(k, 2)`` [m] of element ``i`` in its local frame."""
        return self.verts[self.vert_offsets[i] : self.vert_offsets[i + 1]]

    def copy(self) -> "ElementState":
        return ElementState(**{f.name: np.array(getattr(self, f.name)) for f in fields(self)})

    def arrays(self) -> dict[str, np.ndarray]:
        """All arrays by name (for writers)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
