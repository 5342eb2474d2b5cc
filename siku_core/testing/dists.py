"""Fake installed distributions, to test entry-point plugins without ``pip install``.

``importlib.metadata`` finds a distribution by its ``NAME-VERSION.dist-info`` folder on
``sys.path``; :func:`write_dist_info` writes the three files siku reads (``METADATA``,
``entry_points.txt`` and ``top_level.txt``, which maps the import name back to the package for
the versions recorded in output files). Put the folder on ``sys.path`` (e.g. with
``monkeypatch.syspath_prepend``) and rebuild the registry with
``siku_core.plugins.get_registry(refresh=True)``; rebuild it again after the test.
"""
from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from pathlib import Path


def write_dist_info(
    directory: str | Path,
    name: str,
    version: str,
    entry_points: Mapping[str, str],
    top_level: Iterable[str] = (),
    group: str = "siku",
) -> Path:
    """Write ``directory/NAME-VERSION.dist-info`` declaring ``entry_points`` in ``group``.

    ``name`` is the distribution name (``"siku-example-plugin"``), ``entry_points`` maps entry
    point names to ``"package.module"``, ``top_level`` lists the import names it provides.
    Returns the ``.dist-info`` folder.
    """
    norm = re.sub(r"[-_.]+", "_", name).lower()
    d = Path(directory) / f"{norm}-{version}.dist-info"
    d.mkdir(parents=True, exist_ok=True)
    (d / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n", encoding="utf-8"
    )
    lines = [f"[{group}]"] + [f"{k} = {v}" for k, v in entry_points.items()]
    (d / "entry_points.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (d / "top_level.txt").write_text("".join(f"{t}\n" for t in top_level), encoding="utf-8")
    return d


__all__ = ["write_dist_info"]
