"""HDF5 output (h5py) and bit-for-bit restart.

File layout::

    /                  attrs: siku_version, title, scene_file, dt [s], start (ISO or ""),
                              n_elements, radius [m], created (UTC ISO)
    /scene             the scene file text, verbatim
    /plugins           attrs: package -> version of every package that provided a component
    /components        JSON: name and parameters of every component of the run
    /geometry          vert_offsets, verts [m], m [kg], I [kg m²], area [m²], thickness [m],
                       radius [m], flags, material, floe (floe index of each element, -1: none)
    /states            step, time [s], q (T,N,4), V (T,N,2) [m/s], w (T,N) [rad/s],
                       lat, lon (T,N) [deg], fields/NAME (T,N) per-element quantities for
                       maps (speed [m/s], damage [1]): the snapshots
    /diagnostics       step, time [s] and one series per diagnostic
    /breaks            one row per broken joint, in the order they broke: time [s] (model
                       time of the state that broke it), joint, i, j (element indices), lat,
                       lon [deg] (joint midpoint when written), mode (attrs: code -> name:
                       strain, tension, shear, compression, external); written with each
                       snapshot
    /restart           the latest snapshot in full (q, V, w, step, and every component's
                       history arrays under /restart/components/NAME): what a restart reads

Every write is flushed, so a run that stops early leaves a readable file.
"""
from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from siku_core import DataError, Param, __version__, hookimpl
from siku_core.geometry.quat import latlon_of
from siku_core.interfaces import Writer

_GEOMETRY = ("vert_offsets", "verts", "m", "I", "area", "thickness", "radius", "flags",
             "material", "floe")


def _append(group, name: str, value: np.ndarray, compression: str | None) -> None:
    value = np.asarray(value)
    if name not in group:
        group.create_dataset(
            name, data=value[None], maxshape=(None, *value.shape),
            chunks=(1, *value.shape) if value.ndim else (256,), compression=compression,
        )
    else:
        ds = group[name]
        ds.resize(ds.shape[0] + 1, axis=0)
        ds[-1] = value


def _extend(group, name: str, values: np.ndarray) -> None:
    """Append the rows ``values`` to the 1-D dataset ``name`` (created on first use)."""
    values = np.asarray(values)
    if name not in group:
        group.create_dataset(name, data=values, maxshape=(None,), chunks=(1024,))
    elif len(values):
        ds = group[name]
        n = ds.shape[0]
        ds.resize(n + len(values), axis=0)
        ds[n:] = values


def _replace(group, name: str, value: np.ndarray) -> None:
    if name in group:
        del group[name]
    group.create_dataset(name, data=value)


class HDF5Writer(Writer):
    """Element states, diagnostics, scene text and plugin versions in one HDF5 file."""

    name = "hdf5"
    params = {
        "compression": Param("gzip", "", "dataset compression", type=str,
                             choices=("gzip", "lzf", "none")),
    }

    def open(self, sim) -> None:
        import h5py

        path = Path(self.path)
        # a second run() of the same simulation reopens the file this writer created
        reopen = path.exists() and getattr(self, "_created", None) == path.resolve()
        append = reopen or sim.restarted_from is not None and path.exists() and getattr(
            sim, "restart_path", None
        ) is not None and Path(sim.restart_path).resolve() == path.resolve()
        try:
            if path.parent and not path.parent.exists():
                path.parent.mkdir(parents=True, exist_ok=True)
            self.f = h5py.File(path, "a" if append else "w")
        except OSError as exc:
            raise DataError(f"{path}: cannot open output file: {exc}") from None
        self.comp = None if self.p["compression"] == "none" else self.p["compression"]
        f = self.f
        if append:
            self._truncate(sim.step_index if reopen else sim.restarted_from)
            return
        self._created = path.resolve()
        f.attrs["siku_version"] = __version__
        f.attrs["title"] = sim.scene.cfg.title
        f.attrs["scene_file"] = str(sim.scene.path or "")
        f.attrs["dt"] = sim.dt
        f.attrs["start"] = sim.start.isoformat() if sim.start else ""
        f.attrs["n_elements"] = sim.state.n
        f.attrs["radius"] = sim.radius
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat()
        f.create_dataset("scene", data=sim.scene.text)
        g = f.create_group("plugins")
        for pkg, ver in sim.plugin_versions().items():
            g.attrs[pkg] = ver
        f.create_dataset("components", data=json.dumps(
            [dict(kind=c.kind, **c.describe()) for c in sim.components()], default=str))
        geo = f.create_group("geometry")
        for k in _GEOMETRY:
            geo.create_dataset(k, data=getattr(sim.state, k))
        f.create_group("states")
        f.create_group("diagnostics")
        if sim.contacts is not None and sim.contacts.n_joints:
            from siku_core.contacts import BREAK_MODES

            b = f.create_group("breaks")
            for code, name in BREAK_MODES.items():
                b.attrs[f"mode_{code}"] = name
        f.flush()

    def _truncate(self, step: int) -> None:
        """Drop rows written after ``step`` (from a run that went on past its last restart)."""
        if "breaks" in self.f and "time" in self.f["breaks"]:
            b = self.f["breaks"]
            keep = int(np.count_nonzero(b["time"][:] < step * float(self.f.attrs["dt"])))
            for d in b.values():
                d.resize(keep, axis=0)
        for gname in ("states", "diagnostics"):
            g = self.f[gname]
            if "step" not in g:
                continue
            keep = int(np.searchsorted(g["step"][:], step, side="right"))
            for k, ds in g.items():
                for d in ds.values() if hasattr(ds, "values") else (ds,):
                    d.resize(keep, axis=0)

    def write_state(self, sim) -> None:
        st = sim.state
        g = self.f["states"]
        if "step" in g and g["step"].shape[0] and g["step"][-1] == sim.step_index:
            return
        lat, lon = latlon_of(st.q)
        for name, val in (("step", np.int64(sim.step_index)), ("time", sim.time), ("q", st.q),
                          ("V", st.V), ("w", st.w), ("lat", np.degrees(lat)),
                          ("lon", np.degrees(lon))):
            _append(g, name, val, self.comp if np.ndim(val) else None)
        fields = g.require_group("fields")
        for name, val in sim.element_fields().items():
            _append(fields, name, val, self.comp)
        self._write_breaks(sim)
        r = self.f.require_group("restart")
        for k in ("q", "V", "w"):
            _replace(r, k, getattr(st, k))
        r.attrs["step"] = sim.step_index
        r.attrs["time"] = sim.time
        comps = r.require_group("components")
        for key, arrays in sim.history_arrays().items():
            cg = comps.require_group(key)
            for name, arr in arrays.items():
                _replace(cg, name, arr)
        self.f.flush()

    def _write_breaks(self, sim) -> None:
        cm = sim.contacts
        if cm is None or not cm.n_joints or "breaks" not in self.f:
            return
        rows = cm.take_breaks()
        g = self.f["breaks"]
        for name, val in rows.items():
            _extend(g, name, val)

    def write_diagnostics(self, sim, diag: Mapping[str, Any]) -> None:
        g = self.f["diagnostics"]
        if "step" in g and g["step"].shape[0] and g["step"][-1] == diag["step"]:
            return
        for k, v in diag.items():
            _append(g, k, np.asarray(v), None)
        self.f.flush()

    def close(self, sim) -> None:
        f = getattr(self, "f", None)
        if f is not None and f.id.valid:
            f.close()

    @classmethod
    def read_restart(cls, path, sim) -> dict:
        """Load the latest snapshot of ``path`` into ``sim`` (state and component history)."""
        import h5py

        path = Path(path)
        if not path.is_file():
            raise DataError(f"{path}: restart file not found")
        try:
            with h5py.File(path, "r") as f:
                if "restart" not in f:
                    raise DataError(f"{path}: no restart data (was it written by siku?)")
                r = f["restart"]
                n = r["q"].shape[0]
                if n != sim.state.n:
                    raise DataError(
                        f"{path}: restart has {n} elements but the scene builds {sim.state.n}"
                    )
                for k in ("q", "V", "w"):
                    getattr(sim.state, k)[...] = r[k][...]
                step = int(r.attrs["step"])
                hist = {}
                if "components" in r:
                    for key, g in r["components"].items():
                        hist[key] = {name: ds[...] for name, ds in g.items()}
        except OSError as exc:
            raise DataError(f"{path}: cannot read restart file: {exc}") from None
        sim.step_index = step
        sim.restart_path = path
        sim.set_history_arrays(hist)
        return {"step": step}


@hookimpl
def siku_register_writers():
    return [HDF5Writer]
