"""Thickness categories of the elements: the thickness distribution ``g(h)`` of Kulchitsky et
al. 2017 (the Siku final report, OCS Study BOEM 2017-043), carried per element.

An element may describe its ice by ``K`` categories: the area fraction ``a_k`` [1] of the
element covered by ice of category ``k`` (``sum_k a_k <= 1``; the element's concentration) and
that ice's thickness ``h_k`` [m] (``>= 0``). The element's thickness is the mean over its ice,

    h = sum_k a_k h_k / sum_k a_k

(:func:`category_mean`), used where the ice's own thickness counts (in-plane stiffness ``E h``,
plastic limits, drafts). Its ice volume counts only the ice, the concentration ``sum_k a_k``
included (:func:`element_volume`):

    V = A sum_k a_k h_k        (A the element's area [m²]; V [m³])

so its mass is ``m = rho V`` and its polar moment ``I = rho J sum_k a_k h_k`` (``J`` the
polygon's polar second moment of area [m⁴]): an element whose fractions sum to ``c < 1``
weighs ``c`` times what a full cover of its mean thickness would. A scene has
categories when one of its element sources gives them (an ``[elements.mesh.cover]`` with
``category``) or one of its processes needs a concentration per element (one category, all
ice: :func:`one_category`); an element its source gives no categories (coast and landfast
cells, the elements of other sources) has all its ice in the first category (``a = (1, 0,
..., 0)``) and every category at its thickness. A scene without categories allocates nothing here.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import njit

from .errors import SceneError
from .fields import CATEGORIES

#: how far the fractions of one element may sum above 1 (single-precision data rounded)
SUM_TOLERANCE = 1e-6

#: name -> (units, long name) of the per-element, per-category fields (dimension ``category``)
CATEGORY_FIELDS = {n: (f.units, f.long_name) for n, f in CATEGORIES.items()}


def ice_per_area(thickness: np.ndarray, categories: Categories | None = None) -> np.ndarray:
    """Ice volume per unit element area [m] of every element: ``thickness`` itself (the same
    array) without categories, ``sum_k a_k h_k`` with them (module docstring). The one rule
    siku's mass, inertia and volume budgets use."""
    if categories is None:
        return thickness
    return np.sum(categories.fraction * categories.thickness, axis=1)


def element_volume(area: np.ndarray, thickness: np.ndarray,
                   categories: Categories | None = None) -> np.ndarray:
    """Ice volume [m³] of every element of ``area`` [m²] and ``thickness`` [m]: ``A h``, or
    ``A sum_k a_k h_k`` with categories (:func:`ice_per_area`)."""
    return area * ice_per_area(thickness, categories)


def category_mean(a: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The thickness ``sum_k a_k h_k / sum_k a_k`` [m] of each row of ``a``, ``h`` ``(n, K)``
    (the one formula every part of siku uses, so that the element thickness equals it to the
    last bit)."""
    return np.sum(a * h, axis=1) / np.sum(a, axis=1)


@njit(cache=True, inline="always")
def row_sum(x):
    """``np.sum`` of the 1-D array ``x`` with NumPy's own order of additions (pairwise in
    blocks of eight, as ``np.sum(..., axis=1)`` of a row of up to 128 values), so that a
    compiled loop gives the same bits as :func:`category_mean`."""
    n = x.shape[0]
    if n < 8:
        s = 0.0
        for k in range(n):
            s += x[k]
        return s
    r0, r1, r2, r3, r4, r5, r6, r7 = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7]
    i = 8
    while i < n - n % 8:
        r0 += x[i]
        r1 += x[i + 1]
        r2 += x[i + 2]
        r3 += x[i + 3]
        r4 += x[i + 4]
        r5 += x[i + 5]
        r6 += x[i + 6]
        r7 += x[i + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        s += x[i]
        i += 1
    return s


@njit(cache=True)
def row_mean(a, h, scratch):
    """:func:`category_mean` of one element's fractions ``a`` and thicknesses ``h`` (1-D, ``K``)
    in a compiled loop, the same bits for up to 128 categories; ``scratch`` holds ``K``
    values."""
    for k in range(a.shape[0]):
        scratch[k] = a[k] * h[k]
    return row_sum(scratch) / row_sum(a)


def category_problem(a: np.ndarray, h: np.ndarray) -> tuple[int, str] | None:
    """``(row, what)`` of the first row of ``a``, ``h`` ``(n, K)`` that is not a thickness
    distribution (a fraction negative or not finite, fractions summing above 1 or to 0, a
    thickness negative or not finite, a mean thickness that is not positive); ``None`` when
    every row is one."""
    a = np.asarray(a, dtype=float)
    h = np.asarray(h, dtype=float)
    total = a.sum(axis=1) if a.size else np.zeros(len(a))
    checks = (
        (~np.isfinite(a) | (a < 0)).any(axis=1), "a category fraction is negative or missing",
        total > 1.0 + SUM_TOLERANCE, "the category fractions sum to more than 1",
        ~(total > 0), "the category fractions sum to 0 (no ice)",
        (~np.isfinite(h) | (h < 0)).any(axis=1), "a category thickness is negative or missing",
    )
    for bad, what in zip(checks[::2], checks[1::2]):
        if bad.any():
            i = int(np.argmax(bad))
            return i, f"{what} (fractions {_list(a[i])}, thicknesses {_list(h[i])} m)"
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = category_mean(a, h)
    bad = ~(mean > 0)
    if bad.any():
        i = int(np.argmax(bad))
        return i, f"its ice has no thickness (fractions {_list(a[i])}, thicknesses " \
                  f"{_list(h[i])} m)"
    return None


def _list(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"


@dataclass
class Categories:
    """The thickness categories of a run's elements: ``fraction`` ``a_k`` [1] and
    ``thickness`` ``h_k`` [m], ``(n, K)`` float64 arrays that processes change in place."""

    fraction: np.ndarray
    thickness: np.ndarray

    @property
    def K(self) -> int:
        return self.fraction.shape[1]

    def mean(self) -> np.ndarray:
        """The element thicknesses they give (:func:`category_mean`) [m]."""
        return category_mean(self.fraction, self.thickness)


def one_category(thickness: np.ndarray) -> Categories:
    """One category per element, all of its area ice of its thickness (``a = 1``, ``h_1 = h``
    [m]): the categories of a scene whose sources give none but one of whose processes needs
    an ice concentration per element (:attr:`~siku_core.interfaces.Process.needs_categories`).
    Mass, inertia and the thickness are those of the scene without categories, to the bit
    (``1.0 h = h``)."""
    h = np.asarray(thickness, dtype=float)
    return Categories(np.ones((len(h), 1)), h[:, None].copy())


def categories_of(given: Sequence[tuple[np.ndarray, np.ndarray] | None],
                  thickness: np.ndarray, labels: Sequence[str]) -> Categories | None:
    """The :class:`Categories` of elements whose sources gave ``given`` (``(a, h)`` per element,
    ``None`` for an element without) and whose thicknesses are ``thickness`` [m]; ``None`` when
    no element has categories. The thickness of an element with categories is set to their mean
    (:func:`category_mean`). A distribution that is not one, or a different ``K``, is a
    :class:`SceneError` naming the element (``labels``)."""
    sizes = {len(np.asarray(g[0])) for g in given if g is not None}
    if not sizes:
        return None
    if len(sizes) > 1:
        counts = " and ".join(map(str, sorted(sizes)))
        raise SceneError(f"the scene's element sources give {counts} thickness categories; "
                         "all elements must share one set")
    (K,) = sizes
    if K < 1:
        raise SceneError("thickness categories: give at least one category")
    n = len(given)
    a = np.zeros((n, K))
    a[:, 0] = 1.0
    h = np.repeat(np.asarray(thickness, dtype=float)[:, None], K, axis=1)
    rows = [i for i, g in enumerate(given) if g is not None]
    for i in rows:
        ai, hi = (np.asarray(x, dtype=float).reshape(-1) for x in given[i])
        if len(ai) != K or len(hi) != K:
            raise SceneError(f"{labels[i]}: {len(ai)} category fractions and {len(hi)} "
                             f"category thicknesses; give {K} of each")
        a[i], h[i] = ai, hi
    found = category_problem(a[rows], h[rows])
    if found is not None:
        i, what = found
        raise SceneError(f"{labels[rows[i]]}: {what}")
    thickness[rows] = category_mean(a[rows], h[rows])
    return Categories(a, h)
