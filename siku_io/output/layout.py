"""What every dataset and attribute of a siku HDF5 output file means: units (UDUNITS strings, as
CF uses them) and a description. The writer stores them as ``units`` and ``long_name``
attributes; ``docs/reference/output.md`` is the same catalogue as a page (a test checks that
every dataset of a real file is on it and carries these attributes).

Patterns: ``states/fields/NAME`` (per-element fields: the catalogue
:mod:`siku_core.fields`),
``states/history/KEY/NAME`` (a component's history for an exact restart), ``diagnostics/NAME``
(``siku_core.diagnostics.catalogue``).
"""
from __future__ import annotations

from siku_core.fields import ENGINE_FIELDS, STATE_FIELDS

#: root attributes of the file: name -> (units, meaning)
ROOT_ATTRS: dict[str, tuple[str, str]] = {
    "siku_version": ("", "version of siku that wrote the file"),
    "siku_plugin_api": ("", "plugin API version (major.minor) of that siku, "
                        "siku_core.PLUGIN_API_VERSION"),
    "layout": ("1", "version of this file layout"),
    "title": ("", "the scene's title"),
    "scene_file": ("", "path of the scene file as given to the run"),
    "scene_sha256": ("", "SHA-256 of the scene text in /scene"),
    "dt": ("s", "time step (the scene's, shortened where needed so that outputs fall on steps)"),
    "dt_requested": ("s", "time step the scene asks for"),
    "start": ("", "ISO 8601 date and time of model time 0 (empty: the scene sets none)"),
    "n_steps": ("1", "steps the scene asks for"),
    "seed": ("1", "random seed of the run"),
    "n_elements": ("1", "number of elements N"),
    "radius": ("m", "radius of the model Earth (a sphere)"),
}

#: fixed datasets: path -> (units, meaning); "" units: text
DATASETS: dict[str, tuple[str, str]] = {
    "scene": ("", "the scene file text, verbatim (command-line overrides noted at its end)"),
    "run_record": ("", "JSON: effective scene, every component with every parameter, versions"),
    "components": ("", "JSON: kind, name and parameters of every component of the run"),
    "geometry/vert_offsets": ("1", "element i has vertices verts[vert_offsets[i]:"
                              "vert_offsets[i+1]] (N+1 offsets)"),
    "geometry/verts": ("m", "polygon vertices (x, y) in each element's local tangent plane, "
                       "counter-clockwise, centroid at the origin"),
    "geometry/m": ("kg", "element mass"),
    "geometry/I": ("kg m2", "polar moment of inertia about the centroid"),
    "geometry/area": ("m2", "element area"),
    "geometry/thickness": ("m", "element thickness"),
    "geometry/radius": ("m", "bounding radius about the centroid"),
    "geometry/flags": ("1", "element kind (flag_values, flag_meanings)"),
    "geometry/material": ("1", "index of the element's material among the scene's [materials] "
                          "tables, in order"),
    "geometry/floe": ("1", "floe (bonded group of one source floe) of the element, -1: none"),
    "states/step": ("1", "step index of the snapshot; its length counts the complete snapshots"),
    "states/time": ("s", "model time of the snapshot"),
    "states/q": ("1", "unit quaternion (w, x, y, z) rotating the element's local frame onto the "
                 "Earth-fixed frame (z to the north pole, x through 0 deg E)"),
    "states/V": ("m s-1", "velocity of the centroid in the element's local frame (x, y)"),
    **{f"states/{k}": (STATE_FIELDS[n].units, STATE_FIELDS[n].long_name)
       for k, n in (("w", "spin"), ("lat", "lat"), ("lon", "lon"))},
    "diagnostics/step": ("1", "step index of the diagnostics row; its length counts the rows"),
    "diagnostics/time": ("s", "model time of the diagnostics row"),
    "breaks/time": ("s", "model time of the state that broke the joint; its length counts "
                    "the rows"),
    "breaks/joint": ("1", "index of the joint"),
    "breaks/i": ("1", "element on one side of the joint"),
    "breaks/j": ("1", "element on the other side of the joint"),
    "breaks/lat": ("degrees_north", "latitude of the joint midpoint when the row was written"),
    "breaks/lon": ("degrees_east", "longitude of the joint midpoint when the row was written"),
    "breaks/mode": ("1", "how the joint broke (flag_values, flag_meanings)"),
}

#: history datasets of the engine's contact model: name -> (units, meaning)
CONTACT_HISTORY: dict[str, tuple[str, str]] = {
    "intact": ("1", "1 where the joint is intact"),
    "hist": ("1", "the contact law's history columns per joint (history_names of the law; "
             "units as the law documents)"),
    "n_broken_total": ("1", "joints broken since the start of the run"),
    "break_mode": ("1", "break mode of each joint (0: intact; codes as /breaks/mode)"),
    "break_time": ("s", "model time each joint broke (NaN: intact, -inf: before the record)"),
    "joints": ("1", "joints the run holds: built at set-up, then those processes created; the "
               "rows beyond are reserved slots"),
    "pairs": ("1", "the two elements of every joint (-1 in a reserved slot)"),
    "ends_i": ("m", "the joints' ends in their first element's frame"),
    "contact_pairs": ("1", "element pairs (i < j) in contact, under a law with per-contact "
                      "history (contact_history_names); -1 beyond contact_count"),
    "contact_hist": ("1", "the contact law's history columns per pair in contact "
                     "(contact_history_names of the law; units as the law documents); NaN "
                     "beyond contact_count"),
    "contact_count": ("1", "pairs in contact: the rows of contact_pairs and contact_hist that "
                      "hold data"),
}


def describe(path: str, diagnostics: dict[str, tuple[str, str]] | None = None
             ) -> tuple[str, str]:
    """``(units, long_name)`` of the dataset at ``path`` (relative to the root, no leading
    slash); ``diagnostics`` is the diagnostics catalogue of the run."""
    if path in DATASETS:
        return DATASETS[path]
    parts = path.split("/")
    if parts[:2] == ["states", "fields"] and len(parts) == 3:
        spec = ENGINE_FIELDS.get(parts[2])
        return ((spec.units, spec.long_name) if spec is not None else
                ("1", f"per-element field '{parts[2]}' reported by a component"))
    if parts[:2] == ["states", "history"] and len(parts) == 4:
        if parts[2] == "contacts" and parts[3] in CONTACT_HISTORY:
            return CONTACT_HISTORY[parts[3]]
        return ("1", f"history '{parts[3]}' of component {parts[2]}, for an exact restart")
    if parts[0] == "diagnostics" and len(parts) == 2 and diagnostics and parts[1] in diagnostics:
        return diagnostics[parts[1]]
    if parts[0] == "diagnostics":
        return ("1", f"diagnostic '{parts[-1]}'")
    return ("", "")


#: the per-element datasets of ``/geometry`` (attributes of ``siku_core.state.State``)
GEOMETRY = ("vert_offsets", "verts", "m", "I", "area", "thickness", "radius", "flags",
            "material", "floe")


def state_rows(ctx) -> dict:
    """Every per-snapshot dataset's row for the current state of the run ``ctx``, by path in
    ``/states``: ``time`` [s], ``q``, ``V`` [m/s], ``w`` [rad/s], ``lat``, ``lon`` [deg], the
    per-element fields and every component's history."""
    import numpy as np

    from siku_core.geometry.quat import latlon_of

    st = ctx.state
    lat, lon = latlon_of(st.q)
    rows = {"time": np.float64(ctx.time), "q": st.q, "V": st.V, "w": st.w,
            "lat": np.degrees(lat), "lon": np.degrees(lon)}
    for name, val in ctx.element_fields().items():
        rows[f"fields/{name}"] = np.asarray(val)
    for key, arrays in ctx.history().items():
        for name, arr in arrays.items():
            rows[f"history/{key}/{name}"] = np.asarray(arr)
    return rows


def dataset_attrs(path: str, diagnostics: dict, declared: dict, epoch: str | None,
                  dtype=None, standard: dict | None = None) -> dict:
    """The attributes of the dataset at ``path`` of a run's output (HDF5 or Zarr): ``units``
    and ``long_name`` (:func:`describe`; a declared field's from ``declared``, the run's
    ``field_catalogue``, with its ``grid``), the time axes' epoch (``epoch``: the scene's
    start, ``None`` without one), CF flag meanings (of the dataset's ``dtype``) on the coded
    datasets and the CF ``standard_name`` of a per-element field that has one (``standard``:
    the run's ``standard_names()``; ``geometry/thickness`` takes the thickness's)."""
    import numpy as np

    from siku_core.contact_law import BREAK_MODES
    from siku_core.state import FLAG_MEANINGS

    out: dict = {}
    units, long_name = describe(path, diagnostics)
    if path.startswith("states/fields/") and path[14:] in declared:  # siku_core.ice
        units, long_name, out["grid"] = declared[path[14:]]
    if path.endswith("time") and path.count("/") == 1 and epoch:
        units = f"seconds since {epoch}"
    out["units"], out["long_name"] = units, long_name
    field = path[14:] if path.startswith("states/fields/") else (
        "thickness" if path == "geometry/thickness" else None)
    if standard and field in standard:
        out["standard_name"] = standard[field]
    if path in ("geometry/flags", "states/fields/flags"):
        out.update(flag_attrs({v: k for k, v in FLAG_MEANINGS.items()}, dtype))
    if path == "breaks/mode":
        out.update(flag_attrs(BREAK_MODES, np.int8))
    return out


def flag_attrs(names: dict[int, str], dtype) -> dict:
    """CF ``flag_values`` (of the variable's ``dtype``) / ``flag_meanings`` for code -> name."""
    import numpy as np

    codes = sorted(names)
    return {"flag_values": np.array(codes, dtype=dtype),
            "flag_meanings": " ".join(names[c] for c in codes)}
