"""Reading a siku Zarr output store (``siku_io.output.zarr_store``) through the interface the
readers of the HDF5 output use (``h5py``'s): ``f.attrs``, ``f["states"]["q"][:n]``,
``f["scene"][()]``, ``group.items()``. :func:`siku_io.output.results.open_results` returns a
:class:`ZarrFile` for a store, so every reader (``siku info``, ``--restart``, the xarray
engine, ``siku export``) reads both formats with one code.

The store is opened through its consolidated metadata (the root ``zarr.json``), which the
writer replaces in one rename after each complete snapshot: the shapes it records are those of
the complete snapshots, whatever a killed run wrote after them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

#: root attributes that hold what the HDF5 output keeps as text datasets
TEXT = ("scene", "run_record", "components")


class _Text:
    """A text held as a root attribute, read as the HDF5 output's text dataset (``[()]``:
    UTF-8 bytes)."""

    def __init__(self, text: str):
        self.text = text

    def __getitem__(self, key) -> bytes:
        return self.text.encode("utf-8")


class ZarrArray:
    """An array of the store: indexing, ``shape``, ``ndim``, ``dtype`` and ``attrs`` as an
    ``h5py.Dataset`` (CF ``flag_values`` in the array's type)."""

    def __init__(self, array):
        self.array = array
        self.shape = tuple(array.shape)
        self.ndim = len(self.shape)
        self.dtype = np.dtype(array.dtype)
        attrs = dict(array.attrs)
        if "flag_values" in attrs:
            attrs["flag_values"] = np.asarray(attrs["flag_values"], dtype=self.dtype)
        self.attrs = attrs

    def __getitem__(self, key):
        return self.array[key]

    def __len__(self) -> int:
        return self.shape[0]


class ZarrGroup:
    """A group of the store, as an ``h5py.Group`` for reading."""

    def __init__(self, group):
        self.group = group
        self.attrs = dict(group.attrs)
        #: the texts of the root (module docstring), apart from its attributes
        self.texts = {k: self.attrs.pop(k) for k in TEXT if not group.path and k in self.attrs}

    def _wrap(self, obj):
        return ZarrGroup(obj) if hasattr(obj, "members") else ZarrArray(obj)

    def __getitem__(self, key: str):
        if key in self.texts:
            return _Text(str(self.texts[key]))
        return self._wrap(self.group[key])

    def __contains__(self, key: str) -> bool:
        if not self.group.path and key in TEXT:
            return key in self.texts
        try:
            self.group[key]
        except KeyError:
            return False
        return True

    def get(self, key: str, default=None):
        return self[key] if key in self else default

    def keys(self) -> list[str]:
        return sorted(self.group.keys())

    def items(self) -> list:
        return [(k, self._wrap(v)) for k, v in sorted(self.group.members())]

    def __iter__(self):
        return iter(self.keys())


class ZarrFile(ZarrGroup):
    """The root of a store opened for reading (a context manager, as ``h5py.File``)."""

    def __init__(self, path: str | Path):
        import warnings

        import zarr

        self.path = Path(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # consolidated metadata: not in the v3 spec yet
            super().__init__(zarr.open_consolidated(str(self.path), mode="r"))

    def close(self) -> None:
        self.group = None

    def __enter__(self) -> "ZarrFile":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
