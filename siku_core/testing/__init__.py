"""Helpers for testing siku and its plugins.

* :mod:`siku_core.testing.scenes`: build small scenes from Python (:func:`scene_text`,
  :func:`make_scene`, :func:`square`).
* :mod:`siku_core.testing.fixtures`: a pytest plugin (loaded through the ``pytest11`` entry point
  of the ``siku`` distribution) with the fixtures ``siku_scene_factory``,
  ``siku_simulation_factory`` and ``siku_register``.
* :mod:`siku_core.testing.conformance`: the forcing-source conformance suite, as plain
  ``check_*`` functions and as the test class ``TestForcingSourceConformance``.
* :mod:`siku_core.testing.contact_conformance`: the contact-law conformance suite
  (:func:`~siku_core.testing.contact_conformance.check_contact_law`: Newton's third law for both
  evaluators, zero force when apart, compiled evaluator equal to its pure-Python form, finite
  output in degenerate geometry), for built-in and third-party laws alike.
* :mod:`siku_core.testing.process_checks`: the process conformance suite (:func:`check_process`).
* :mod:`siku_core.testing.writer_checks`: the writer conformance suite
  (:func:`~siku_core.testing.writer_checks.check_writer`: partial file then publish, ``owns``,
  ``--overwrite``, restart with no row twice or extra, a run stopped before its first
  snapshot), for any writer by its registered name.
* :mod:`siku_core.testing.element_source_checks`: the element-source conformance suite
  (:func:`~siku_core.testing.element_source_checks.check_element_source`).
* :mod:`siku_core.testing.dists`: :func:`write_dist_info` fakes an installed plugin package, to
  test the entry-point path without ``pip install``.

Importing this package loads neither h5py, netCDF4, xarray nor any plugin.
"""
from __future__ import annotations

from .dists import write_dist_info
from .scenes import make_scene, scene_text, square, toml_value

__all__ = ["make_scene", "scene_text", "square", "toml_value", "write_dist_info"]
