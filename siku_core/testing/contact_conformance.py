"""Conformance suite for contact laws (rheologies), and helpers for contact tests.

Every contact law (a :class:`~siku_core.interfaces.ContactLaw`) must:

1. obey Newton's third law through the engine's apply path, for its collision evaluator and,
   for joint laws, its joint evaluator (:func:`check_newton_third_law`). On a sphere the exact
   statement is about torques: the contributions of a pair to the torque about the planet centre
   cancel (to round-off), so the pair conserves its angular momentum about the planet centre.
   The tangential forces of the two elements live in two tangent planes; mapped to the global
   frame they cancel up to a radial remainder of relative size ``O(d / R)`` (``d`` the distance
   between the centres), which is checked with that bound;
2. exert no force on a separated pair without a joint (:func:`check_zero_force_when_apart`);
3. have compiled evaluators equal to their pure-Python form (``evaluator.py_func``) on random
   geometry vectors, history updates and break flags included
   (:func:`check_compiled_matches_python`);
4. give finite output in degenerate geometry: zero overlap area, zero contact width, a joint
   whose two ends coincide (zero width), two coincident elements, two elements that only touch
   (:func:`check_degenerate_finite`);
5. be passive: over a push–release cycle of an isolated pair (one element driven along a
   closed path of rigid motions, the other held), the work the contact does on the driven
   element never exceeds zero: a contact cannot give back more energy than was put into it
   (:func:`check_passivity`; catches anti-springs and negative damping);
6. derive its joint force and couple from its stored energy, where the law declares one
   (``joint_energy(g, pars, hist) -> J``; :func:`check_energy`);
7. change its history only as it declares (:func:`check_history`): only its
   ``history_names`` columns, and with ``history_update = "state"`` (the default: maxima,
   failure flags, damage) evaluating the same geometry again changes nothing; with ``"rate"``
   (history integrated over the time step) nothing changes again at ``dt = 0``; a law with
   per-contact history (``contact_history_names``) has its collision evaluator called with
   the contact's row, ``(g, pars, hist, out)``, in every check, and writes no column past them;
8. keep everything a run needs in its history (:func:`check_restart`): a run stopped at a
   snapshot and continued from the file equals the run that never stopped, bit for bit, for
   an overlapping pair (the contact rows) and a jointed pair (the joints' rows).

An evaluator that raises (a 0/0, a domain error) or returns non-finite numbers is reported as a
finding of the check that met it, with the geometry. Every message starts with the law's name
and the check's, e.g. ``anti_spring: passivity: ...``.

:func:`check_contact_law` runs them all on a law class, registered or not:

.. code-block:: python

    from siku_core.testing.contact_conformance import check_contact_law
    from my_package.laws import MyLaw

    def test_my_law_conforms():
        check_contact_law(MyLaw, params={"stiffness": 2.0})

The geometry vectors follow the layouts ``G_*`` / ``J_*`` of :mod:`siku_core.contact_law`;
:func:`collision_geometry` and :func:`joint_geometry` build one from named entries for a
pure-Python test of an evaluator, :func:`contact_history_row` the row a law with per-contact
history takes. The scene helpers (:func:`contact_scene_text`, :func:`square_pack`,
:func:`rotate_about`, ...) are shared with siku's own contact tests.

The suite is split by concern: :mod:`~siku_core.testing.contact_cases` (scenes, scene
helpers, geometry vectors), :mod:`~siku_core.testing.contact_force_checks` (checks 1-4),
:mod:`~siku_core.testing.contact_energy_checks` (checks 5-7) and
:mod:`~siku_core.testing.contact_restart_checks` (check 8); this module gathers them.
Importing this module loads numba and siku's engine
modules, but neither h5py, netCDF4, xarray nor any plugin.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .contact_cases import (  # noqa: F401 - the suite's names, read from here
    axis_angle,
    collision_geometry,
    contact_forces,
    contact_history_row,
    contact_scene,
    contact_scene_text,
    degenerate_collision_geometries,
    degenerate_joint_geometries,
    global_forces,
    global_torques,
    joint_geometry,
    law_registry,
    law_simulation,
    pull_apart,
    random_collision_geometry,
    random_joint_geometry,
    rotate_about,
    square_pack,
)
from .contact_energy_checks import (  # noqa: F401 - the suite's names, read from here
    check_energy,
    check_history,
    check_passivity,
)
from .contact_force_checks import (  # noqa: F401 - the suite's names, read from here
    check_compiled_matches_python,
    check_degenerate_finite,
    check_newton_third_law,
    check_zero_force_when_apart,
)
from .contact_restart_checks import check_restart  # noqa: F401 - the suite's names
from .scenes import square  # noqa: F401 - the suite's names, read from here


def check_contact_law(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Run every contact-law conformance check on ``law_cls`` (registered or not) with the
    given parameters (defaults otherwise). The checks that call the evaluators alone come
    first: a law they fail is reported before the engine's contact loops are compiled for its
    evaluators (a minute or more of compiling for a new collision evaluator)."""
    check_history(law_cls, params)
    check_compiled_matches_python(law_cls, params)
    check_newton_third_law(law_cls, params)
    check_zero_force_when_apart(law_cls, params)
    check_degenerate_finite(law_cls, params)
    check_passivity(law_cls, params)
    check_energy(law_cls, params)
    check_restart(law_cls, params)


__all__ = [
    "axis_angle", "check_compiled_matches_python", "check_contact_law",
    "check_degenerate_finite", "check_energy", "check_history", "check_newton_third_law",
    "check_passivity", "check_restart", "check_zero_force_when_apart", "collision_geometry",
    "contact_forces", "contact_history_row", "contact_scene", "contact_scene_text",
    "degenerate_collision_geometries", "degenerate_joint_geometries", "global_forces",
    "global_torques", "joint_geometry", "law_registry",
    "law_simulation", "pull_apart", "random_collision_geometry", "random_joint_geometry",
    "rotate_about", "square", "square_pack",
]
