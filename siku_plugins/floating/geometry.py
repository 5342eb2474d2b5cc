"""Waterplane of a floating element: the polygon's area, its second moments of area about the
centroid and their principal axes, and the quadrature points on which the wave pressure is
integrated.

For a convex polygon with vertices ``(x_k, y_k)`` counter-clockwise about its centroid (the
element's local frame, [m]), the second moments of area [m⁴] are, with ``c_k = x_k y_{k+1} -
x_{k+1} y_k``,

    I_xx = sum (y_k² + y_k y_{k+1} + y_{k+1}²) c_k / 12       (= ∫ y² dA)
    I_yy = sum (x_k² + x_k x_{k+1} + x_{k+1}²) c_k / 12       (= ∫ x² dA)
    I_xy = sum (x_k y_{k+1} + 2 x_k y_k + 2 x_{k+1} y_{k+1} + x_{k+1} y_k) c_k / 24

and the principal axes are the eigenvectors of ``[[∫x², ∫xy], [∫xy, ∫y²]]``: axis 1 along
angle ``phi`` from local x, with moment ``J1 = ∫ u² dA`` (``u`` the coordinate along axis 1),
axis 2 perpendicular with ``J2 = ∫ v² dA``.

Quadrature: the polygon is cut into the triangles (centroid, v_k, v_{k+1}), each triangle into
``n²`` similar ones, and each small triangle carries the three-point rule exact for
polynomials of degree 2 (points at 1/6, 1/6, 2/3 of the barycentric coordinates, weights a
third of its area). The rule integrates a plane wave over the element with an error of order
``(k s)³`` for a sub-triangle of size ``s``; ``tests/test_floating.py`` compares it with the
exact transform of a rectangle.
"""
from __future__ import annotations

import math

import numpy as np


def second_moments(poly: np.ndarray) -> tuple[float, float, float, float]:
    """``(area [m²], ∫x² dA, ∫y² dA, ∫xy dA [m⁴])`` of a counter-clockwise polygon ``(k, 2)``
    about the origin."""
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    c = x * y1 - x1 * y
    area = c.sum() / 2.0
    ixx = float(np.sum((x * x + x * x1 + x1 * x1) * c) / 12.0)
    iyy = float(np.sum((y * y + y * y1 + y1 * y1) * c) / 12.0)
    ixy = float(np.sum((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * c) / 24.0)
    return float(area), ixx, iyy, ixy


def principal(ixx: float, iyy: float, ixy: float) -> tuple[float, float, float]:
    """``(phi [rad], J1, J2 [m⁴])``: the angle of principal axis 1 from local x and the second
    moments ``∫u² dA`` along axis 1 and ``∫v² dA`` along axis 2 (``ixx = ∫x²``, ``iyy =
    ∫y²``, ``ixy = ∫xy``). A waterplane whose two moments are equal to 1e-4 (a square, a
    regular polygon: every axis is principal, or nearly) keeps the local axes, ``phi = 0``,
    rather than an angle that round-off would choose."""
    if abs(2.0 * ixy) + abs(ixx - iyy) <= 1e-4 * (ixx + iyy):
        return 0.0, ixx, iyy
    phi = 0.5 * math.atan2(2.0 * ixy, ixx - iyy)
    c, s = math.cos(phi), math.sin(phi)
    j1 = c * c * ixx + 2 * c * s * ixy + s * s * iyy
    j2 = s * s * ixx - 2 * c * s * ixy + c * c * iyy
    return phi, j1, j2


#: barycentric coordinates of the three-point rule of degree 2
_BARY = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])


def quadrature(poly: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(Q, 2)`` [m] and weights ``(Q,)`` [m²] on the polygon (module docstring),
    ``Q = 3 n² k`` for ``k`` vertices; the weights sum to the area."""
    pts = []
    wts = []
    k = len(poly)
    # the small triangles of a triangle (a, b, c) in barycentric steps of 1/n
    for e in range(k):
        a = np.zeros(2)
        b = poly[e]
        c = poly[(e + 1) % k]
        tri_area = 0.5 * abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
        small = tri_area / (n * n)
        for i in range(n):
            for j in range(n - i):
                # upward triangle with corners at grid nodes (i, j), (i+1, j), (i, j+1)
                corners = [(i, j), (i + 1, j), (i, j + 1)]
                tris = [corners]
                if i + j < n - 1:
                    tris.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
                for tri in tris:
                    P = np.array([a + (u / n) * (b - a) + (v / n) * (c - a) for u, v in tri])
                    pts.append(_BARY @ P)
                    wts.append(np.full(3, small / 3.0))
    return np.concatenate(pts), np.concatenate(wts)


def quadrature_lattice(k: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points of :func:`quadrature` on a polygon of ``k`` vertices ``v`` as whole
    multiples of ``v / (6 n)``: point ``p`` is ``(beta_p v_e + gamma_p v_{e+1}) / (6 n)``,
    ``e = edge_p`` (the edge triangle it lies in), in :func:`quadrature`'s order. A plane
    wave's phase at the points is then ``beta_p phi_e + gamma_p phi_{e+1}``, ``phi_v`` the
    phase at ``v / (6 n)``: a point's ``e^{i delta}`` is a product of two powers of the
    vertices' (``siku_plugins.floating.kernels``)."""
    six = np.rint(6 * _BARY).astype(np.int64)
    edge, beta, gamma = [], [], []
    for e in range(k):
        for i in range(n):
            for j in range(n - i):
                tris = [[(i, j), (i + 1, j), (i, j + 1)]]
                if i + j < n - 1:
                    tris.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
                for tri in tris:
                    uv = np.array(tri, dtype=np.int64)
                    b = six @ uv
                    edge.extend([e] * 3)
                    beta.extend(b[:, 0])
                    gamma.extend(b[:, 1])
    return (np.array(edge, dtype=np.int64), np.array(beta, dtype=np.int64),
            np.array(gamma, dtype=np.int64))


def lattice_arrays(items: list) -> tuple:
    """The vertices and lattice of :func:`quadrature_lattice` of every element, concatenated
    for the kernels: ``items[i]`` is ``(polygon, n)`` of element ``i`` (``None`` for one
    without quadrature points). Returns ``(voff, vx, vy, m6, ia, ib, zsize)``: element ``i``'s
    vertices ``vx[voff[i]:voff[i + 1]]``, its ``6 n`` in ``m6[i]`` (0 without points), and per
    point where its two factors lie in the kernel's table of powers (``z_v^m`` of vertex ``v``
    at rows ``2 (v (6 n - 1) + m)`` and the next: cosine, sine), whose length is ``zsize``."""
    voff, vx, vy, m6, ia, ib = [0], [], [], [], [], []
    zsize = 2
    for it in items:
        if it is None:
            voff.append(voff[-1])
            m6.append(0)
            continue
        poly, n = it
        k = len(poly)
        e, b, g = quadrature_lattice(k, n)
        w = 6 * n - 1
        voff.append(voff[-1] + k)
        vx.append(poly[:, 0])
        vy.append(poly[:, 1])
        m6.append(6 * n)
        ia.append(2 * (e * w + b))
        ib.append(2 * (((e + 1) % k) * w + g))
        zsize = max(zsize, 2 * k * w)

    def cat(x, dtype):
        return np.concatenate(x).astype(dtype) if x else np.zeros(0, dtype=dtype)

    return (np.array(voff, dtype=np.int64), cat(vx, float), cat(vy, float),
            np.array(m6, dtype=np.int64), cat(ia, np.int64), cat(ib, np.int64), zsize)
