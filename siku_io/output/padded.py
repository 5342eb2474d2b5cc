"""Ragged snapshot datasets of the HDF5 output: history arrays whose first axis (one entry
per contact) changes length from snapshot to snapshot (``siku_core.run.restart.RAGGED_HISTORY``:
the per-contact history of a law with ``contact_history_names``). A dataset ``(T, M, ...)``
grows along ``M`` to the longest row written; shorter rows are padded with -1 (integers) or
NaN (floats), and the component's count (``contact_count``) says how many entries are real.
"""
from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from siku_core.run.restart import RAGGED_HISTORY


def is_padded(name: str) -> bool:
    """Whether the snapshot dataset ``name`` (relative to ``/states``) is ragged."""
    return name.startswith("history/") and name.rpartition("/")[2] in RAGGED_HISTORY


def pad_value(dtype) -> Any:
    """What pads a ragged dataset: NaN for floats, -1 for integers."""
    return np.nan if np.dtype(dtype).kind == "f" else -1


#: the ragged datasets made by :func:`new_padded`, by ``id`` (weakly held)
_MADE: weakref.WeakValueDictionary = weakref.WeakValueDictionary()


def new_padded(group, name: str, row: np.ndarray, compression: str | None):
    """An empty ragged dataset for rows shaped like ``row`` (any length along its first axis);
    the writer's appends then go to :func:`append_padded` (:func:`made_padded`)."""
    row = np.asarray(row)
    ds = group.create_dataset(
        name, shape=(0, *row.shape), maxshape=(None, None, *row.shape[1:]), dtype=row.dtype,
        chunks=(1, 256, *(max(d, 1) for d in row.shape[1:])), compression=compression,
        fillvalue=pad_value(row.dtype))
    _MADE[id(ds)] = ds
    return ds


def made_padded(ds) -> bool:
    """Whether ``ds`` is a ragged dataset made by :func:`new_padded` in this process."""
    return _MADE.get(id(ds)) is ds


def append_padded(ds, values, rows: int) -> None:
    """Append ``rows`` rows ``values`` (``(rows, m, ...)``, or one row ``(m, ...)`` when
    ``rows == 1``) to the ragged dataset ``ds``: it grows along its second axis to the longest
    and shorter rows are padded (:func:`pad_value`). Works under SWMR (datasets only grow)."""
    arr = np.asarray(values)
    if rows == 1 and arr.ndim == ds.ndim - 1:
        arr = arr[None]
    m = max(ds.shape[1], arr.shape[1])
    if m > ds.shape[1]:
        ds.resize(m, axis=1)
    if arr.shape[1] < m:
        full = np.full((arr.shape[0], m, *arr.shape[2:]), pad_value(ds.dtype), dtype=ds.dtype)
        full[:, :arr.shape[1]] = arr
        arr = full
    n = ds.shape[0]
    ds.resize(n + rows, axis=0)
    if rows:
        ds[n:] = arr
