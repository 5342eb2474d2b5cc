"""How a wave field sums its sea: the ``method`` key of the ``jonswap`` field.

``direct``: a cosine and a sine per component and point (:mod:`siku_forcing.waves.wave_field`);
``lines``: the sea tabulated along each direction and interpolated, within ``tolerance`` of the
direct sum (:mod:`siku_forcing.waves.wave_lines`).
"""
from __future__ import annotations

import numpy as np

from siku_core import Param

LINES_PARAMS = {
    "method": Param("direct", "", "direct (a cosine and a sine per component and point) or "
                    "lines (tabulated along each direction and interpolated: "
                    "siku_forcing.waves.wave_lines)", type=str, choices=("direct", "lines")),
    "tolerance": Param(1e-6, "1", "lines: bound of the interpolation error over the summed "
                       "amplitudes", min=1e-12, max=0.1),
}


class LinesMixin:
    """``evaluate``, ``curvature`` and ``add_forces`` of a wave field with :data:`LINES_PARAMS`:
    the field's own direct sums, or its :class:`siku_forcing.waves.wave_lines.LineSea`."""

    _line_sea = None

    def _build(self):
        super()._build()
        self._line_sea = None

    def _lines(self):
        """The tables of ``method = "lines"``, or None."""
        if self.p.get("method", "direct") != "lines":
            return None
        self._args()
        if self._line_sea is None:
            from .wave_lines import LineSea

            self._line_sea = LineSea(self, self.p["tolerance"])
        return self._line_sea

    def evaluate(self, t, lat, lon) -> dict[str, np.ndarray]:
        lines = self._lines()
        if lines is None:
            return super().evaluate(t, lat, lon)
        r = lines.evaluate(t, lat, lon)
        return {"eta": r[:, 0], "eta_e": r[:, 1], "eta_n": r[:, 2], "u": r[:, 3], "v": r[:, 4]}

    def curvature(self, t, lat, lon, se, sn) -> np.ndarray:
        lines = self._lines()
        return (super() if lines is None else lines).curvature(t, lat, lon, se, sn)

    def add_forces(self, t, q, V, st, free, g, slope, drag, F) -> None:
        """The ``waves`` forcing (slope force and drag on the free elements) with the direct
        sum per element, or with the interpolated sea."""
        if drag == 0.0 and not slope:
            return
        from siku_core.geometry.quat import latlon_of

        from .wave_kernels import add_slope_drag, wave_forces

        lines = self._lines()
        if lines is None:
            wave_forces(float(t), q, V, st.m, st.area, free, self.plane_waves(), g, slope,
                        drag, F)
            return
        r = lines.evaluate(t, *latlon_of(q))
        add_slope_drag(q, V, st.m, st.area, free, r, g, slope, drag, F, np.zeros(len(q)))
