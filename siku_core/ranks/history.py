"""A process's own history on ranks: split into the ranks' parts and joined again by global
identities.

A process that keeps state of its own between steps (``history()``, ``set_history(arrays)``)
runs on ranks when it says how each of its arrays is indexed, in ``rank_history`` (a class
attribute: ``{array name: layout}``). Each rank's copy of the process holds the rows of the
elements, joints and pairs that rank holds, in local indices; the run's copy holds the whole,
in global ones. Layouts (:data:`LAYOUTS`):

``"element"``
    one row per element (first axis): the owner's row is the run's.
``"joint"``
    one row per joint slot (first axis): the row of the rank that reports the joint (the owner
    of its first element) is the run's.
``"pair_keys"``
    sorted keys ``min(i, j) n + max(i, j)`` of unordered element pairs, ``-1`` after the last
    (``n``: the elements the copy holds); the pairs whose smaller element a rank owns are its.
    At most one such array per process.
``"pair_rows"``
    rows aligned with the ``"pair_keys"`` array (its companions), 0 after the last.
``"pair_times"``
    rows aligned with the ``"pair_keys"`` array that hold a time or another float with no
    value after the last (NaN there).
``"pair_elements"``
    rows aligned with the ``"pair_keys"`` array that name one element of their pair (an index
    of the copy's elements, ``-1``: none), ``-1`` after the last: translated between local and
    global indices as the keys are.
``"pair_count"``
    how many keys of the ``"pair_keys"`` array are in use (a scalar).
``"same"``
    a value every rank's copy holds alike (a scalar or array: the position of a ring buffer
    that every element's row shares, a clock): the run's is the first rank's.
``"total"``
    a count over the whole run of what the process did (a scalar): the run's value is the sum
    of the ranks' values. A process keeps it exact by adding what the contacts view's actions
    return (and, for the joints it creates, ``n_reported``): on ranks they count only the
    joints the rank reports, so each is counted once.

A layout may name arrays that a process's configuration does not keep (``refreeze`` keeps its
followed pairs only with ``weld = true``): those are left out.

:func:`to_global` takes a rank's part of a process's history, :func:`merge` joins the ranks'
parts into the run's history, :func:`to_local` gives a rank's copy its part of the run's.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import SceneError

LAYOUTS = ("element", "joint", "pair_keys", "pair_rows", "pair_times", "pair_elements",
           "pair_count", "same", "total")


def unfit(comp) -> str:
    """Why the history of component ``comp`` cannot go between ranks ("" where it can, or
    where it keeps none)."""
    hist = comp.history()
    if hist is None:
        return ""
    layout = dict(comp.rank_history or {})
    missing = sorted(set(hist) - set(layout))
    if missing:
        return ("it keeps history of its own for restarts that ranks do not carry (no "
                f"rank_history layout for {', '.join(missing)})")
    bad = sorted(k for k, v in layout.items() if v not in LAYOUTS)
    if bad:
        return f"its rank_history names an unknown layout for {', '.join(bad)}"
    keys = [k for k, v in layout.items() if v == "pair_keys"]
    if len(keys) > 1:
        return "its rank_history has more than one pair_keys array"
    return ""


def _kept(layout: dict[str, str], hist: dict[str, Any]) -> dict[str, str]:
    """The entries of ``layout`` whose arrays ``hist`` holds."""
    return {k: v for k, v in layout.items() if k in hist}


def _pair_names(layout: dict[str, str]) -> tuple[str | None, list[str], str | None]:
    keys = next((k for k, v in layout.items() if v == "pair_keys"), None)
    rows = [k for k, v in layout.items() if v in ("pair_rows", "pair_times", "pair_elements")]
    count = next((k for k, v in layout.items() if v == "pair_count"), None)
    return keys, rows, count


def _elements_of(layout: dict[str, str]) -> set[str]:
    return {k for k, v in layout.items() if v == "pair_elements"}


def _fill(layout: dict[str, str], name: str) -> float:
    """The value of a pair array ``name`` after the last pair."""
    return {"pair_elements": -1, "pair_times": np.nan}.get(layout[name], 0)


def _translate(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Element indices ``rows`` (``-1``: none) through ``table`` (index -> index)."""
    out = np.array(rows, copy=True)
    use = out >= 0
    out[use] = table[out[use]]
    return out


def to_global(layout: dict[str, str], hist: dict[str, np.ndarray], ids: np.ndarray,
              own: np.ndarray, jg: np.ndarray, j_mine: np.ndarray, owner: np.ndarray,
              rank: int, n: int) -> dict[str, Any]:
    """This rank's part of a process's ``hist`` (its copy's, local indices): rows of the
    elements it owns (``own``: local rows), of the joints it reports (``j_mine`` among the
    local joints, whose global indices are ``jg``), the pairs whose smaller element it owns
    (global keys over ``n`` elements), its totals."""
    part: dict[str, Any] = {}
    nl = len(ids)
    layout = _kept(layout, hist)
    kname, rnames, _ = _pair_names(layout)
    for name, kind in layout.items():
        a = np.asarray(hist[name])
        if kind == "element":
            part[name] = a[own]
        elif kind == "joint":
            part[name] = a[:len(jg)][j_mine]
        elif kind in ("total", "same"):
            part[name] = a
    if kname is not None:
        keys = np.asarray(hist[kname])
        use = np.flatnonzero(keys >= 0)
        a, b = ids[keys[use] // max(nl, 1)], ids[keys[use] % max(nl, 1)]
        mine = owner[a] == rank
        part[kname] = a[mine] * n + b[mine]
        for r in rnames:
            part[r] = np.asarray(hist[r])[use[mine]]
            if r in _elements_of(layout):
                part[r] = _translate(part[r], ids)
    return part


def merge(layout: dict[str, str], run_hist: dict[str, np.ndarray],
          parts: list[tuple[np.ndarray, np.ndarray, dict[str, Any]]]) -> dict[str, np.ndarray]:
    """The run's history from its current one ``run_hist`` (for the shapes) and every rank's
    ``(owned element ids, reported joint ids, part)``."""
    out = {k: np.array(v, copy=True) for k, v in run_hist.items()}
    layout = _kept(layout, run_hist)
    kname, rnames, cname = _pair_names(layout)
    for name, kind in layout.items():
        if kind == "element":
            for ids, _, part in parts:
                out[name][ids] = part[name]
        elif kind == "joint":
            for _, jg, part in parts:
                out[name][jg] = part[name]
        elif kind == "total":
            total = np.zeros_like(out[name])
            for _, _, part in parts:
                total = total + part[name]
            out[name] = np.asarray(total, dtype=out[name].dtype)
        elif kind == "same" and parts:
            out[name] = np.array(parts[0][2][name], dtype=out[name].dtype)
    if kname is not None:
        keys = np.concatenate([p[kname] for _, _, p in parts]).astype(np.int64)
        order = np.argsort(keys, kind="stable")
        m = len(keys)
        if m > len(out[kname]):
            raise SceneError(f"the ranks hold {m} pairs of '{kname}', more than its "
                             f"{len(out[kname])}")
        out[kname][:] = -1
        out[kname][:m] = keys[order]
        for r in rnames:
            rows = np.concatenate([p[r] for _, _, p in parts])
            out[r][...] = _fill(layout, r)
            out[r][:m] = rows[order]
        if cname is not None:
            out[cname] = np.asarray(m, dtype=out[cname].dtype)
    return out


def to_local(layout: dict[str, str], run_hist: dict[str, np.ndarray],
             fresh: dict[str, np.ndarray], ids: np.ndarray, jg: np.ndarray, rank: int,
             n: int, where: str) -> dict[str, np.ndarray]:
    """A rank's copy's history (shapes of its ``fresh`` one, just set up) from the run's
    ``run_hist``: the rows of the elements ``ids`` and the joints ``jg`` it holds, the pairs
    of two of its elements (in local keys), the totals on the first rank only."""
    out = {k: np.array(v, copy=True) for k, v in fresh.items()}
    nl = len(ids)
    layout = _kept(layout, fresh)
    kname, rnames, cname = _pair_names(layout)
    for name, kind in layout.items():
        if kind == "element":
            out[name][...] = run_hist[name][ids]
        elif kind == "joint":
            out[name][:len(jg)] = run_hist[name][jg]
        elif kind == "total":
            out[name] = np.asarray(run_hist[name] if rank == 0 else 0,
                                   dtype=np.asarray(run_hist[name]).dtype)
        elif kind == "same":
            out[name] = np.array(run_hist[name], copy=True)
    if kname is not None:
        g = np.asarray(run_hist[kname])
        g = g[g >= 0]
        a, b = g // n, g % n
        la = np.minimum(np.searchsorted(ids, a), max(nl - 1, 0))
        lb = np.minimum(np.searchsorted(ids, b), max(nl - 1, 0))
        held = (ids[la] == a) & (ids[lb] == b) if nl else np.zeros(len(g), bool)
        m = int(held.sum())
        if m > len(out[kname]):
            raise SceneError(f"{where}: a rank holds {m} pairs of '{kname}', more than its "
                             f"{len(out[kname])}; raise the process's capacity")
        out[kname][:] = -1
        out[kname][:m] = la[held] * nl + lb[held]  # (ascending, as the global keys)
        src = np.flatnonzero(np.asarray(run_hist[kname]) >= 0)[held]
        for r in rnames:
            rows = np.asarray(run_hist[r])[src]
            if r in _elements_of(layout):  # global -> local: the pair's elements are held
                local = np.minimum(np.searchsorted(ids, np.maximum(rows, 0)), max(nl - 1, 0))
                rows = np.where(rows >= 0, local, -1)
            out[r][...] = _fill(layout, r)
            out[r][:m] = rows
        if cname is not None:
            out[cname] = np.asarray(m, dtype=np.asarray(fresh[cname]).dtype)
    return out


__all__ = ["LAYOUTS", "merge", "to_global", "to_local", "unfit"]
