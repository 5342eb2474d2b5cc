"""A contact law's contract, in one place.

What a law supplies and what the engine hands it:

* :class:`ContactLaw`, the base class: ``collision_evaluator(g, pars, out)`` for every law,
  ``joint_evaluator(g, pars, hist, out)`` for a law with ``uses_joints = True``, and the
  parameter records ``collision_record`` / ``joint_record`` (:class:`ParameterRecord`) from
  which the engine packs the float64 vectors ``pars``;
* the layouts of the vectors an evaluator reads and writes: the collision geometry ``g``
  (``G_*``, :data:`COLLISION_LAYOUT`), the joint geometry ``g`` (``J_*``,
  :data:`JOINT_LAYOUT`), the result ``out`` (``OUT_*``, :data:`OUT_LAYOUT`); the joint's
  history row ``hist`` has the columns the law names in ``history_names``, and a contact's
  history row (a collision evaluator's ``hist``, laws that declare ``contact_history_names``)
  the columns named there;
* the break modes a joint evaluator writes to ``out[OUT_BREAK]`` (:class:`BreakMode`, the
  ``BREAK_*`` ints, names by code in :data:`BREAK_MODES`);
* the reference signatures of the evaluators (:data:`EVALUATORS`) and the checks run when a
  law registers (:func:`check_contact_law`) and when a run compiles it
  (:func:`compile_evaluators`).

Sign conventions (both evaluators): geometry is expressed in element ``i``'s tangent frame. An
evaluator returns the force on element ``j`` (``out[OUT_FX]``, ``out[OUT_FY]``, N, in ``i``'s
frame) and a couple on ``j`` (``out[OUT_COUPLE]``, N m, about the local vertical). The engine
applies them to ``j`` and the opposite to ``i``, as a 3D force at the contact point on the
sphere, so each pair's contribution to the angular momentum about the planet centre cancels
exactly. Guide: ``docs/howto/contact_laws.md``.
"""
from __future__ import annotations

import inspect
import re
from collections import namedtuple
from collections.abc import Mapping
from enum import IntEnum
from typing import Any, ClassVar

import numpy as np

from .deprecation import warn_deprecated
from .errors import PluginError
from .component import Component

# ---------------------------------------------------------------------- layouts
# collision geometry ``g``
(G_AREA, G_CX, G_CY, G_NX, G_NY, G_WIDTH, G_K, G_MEFF, G_VX, G_VY, G_AREA_I, G_AREA_J, G_HI,
 G_HJ, G_DTM) = range(15)
G_SIZE = 15
# joint geometry ``g``
(J_S1X, J_S1Y, J_S2X, J_S2Y, J_AX, J_AY, J_BX, J_BY, J_L0, J_W, J_K, J_MEFF, J_VAX, J_VAY,
 J_VBX, J_VBY, J_HI, J_HJ, J_EI, J_EJ, J_NU, J_DT, J_DTM) = range(23)
J_SIZE = 23
# what an evaluator writes to ``out``
OUT_FX, OUT_FY, OUT_COUPLE, OUT_BREAK = range(4)
OUT_SIZE = 4

#: the collision geometry vector ``g``: ``(index constant, unit, meaning)`` per entry, in order
#: (rendered for the docs by :func:`layout_table`)
COLLISION_LAYOUT = (
    ("G_AREA", "m²", "overlap area `A`"),
    ("G_CX", "m", "overlap centroid, x (where the force acts)"),
    ("G_CY", "m", "overlap centroid, y"),
    ("G_NX", "1", "unit normal from `i` towards `j`, x"),
    ("G_NY", "1", "unit normal from `i` towards `j`, y"),
    ("G_WIDTH", "m", ("contact width: `|P1P2|` when the boundaries cross twice, else the common "
                     "span of both polygons across the normal")),
    ("G_K", "Pa", "effective stiffness `K` of eq. 9 (0 for coincident centres)"),
    ("G_MEFF", "kg", ("reduced mass `1/(1/m_i + 1/m_j)` (a static or steady element counts as "
                     "infinitely heavy)")),
    ("G_VX", "m/s", "velocity of `j` relative to `i` at the centroid, x"),
    ("G_VY", "m/s", "velocity of `j` relative to `i` at the centroid, y"),
    ("G_AREA_I", "m²", "area of `i`"),
    ("G_AREA_J", "m²", "area of `j`"),
    ("G_HI", "m", "thickness of `i`"),
    ("G_HJ", "m", "thickness of `j`"),
    ("G_DTM", "s/kg", ("the step over the contact's damping mass, `dt / m_d` (0: no bound); a "
                      "damper `c` acts as `step_damper(c, g[G_DTM])`")),
)
#: the joint geometry vector ``g``: ``(index constant, unit, meaning)`` per entry, in order
JOINT_LAYOUT = (
    ("J_S1X", "m", "displacement of the joint's first end, `s1` (`j`'s copy minus `i`'s), x"),
    ("J_S1Y", "m", "`s1`, y"),
    ("J_S2X", "m", "displacement of the second end, `s2`, x"),
    ("J_S2Y", "m", "`s2`, y"),
    ("J_AX", "m", "first end `a` of `i`'s copy of the joint, x"),
    ("J_AY", "m", "`a`, y"),
    ("J_BX", "m", "second end `b`, x (`a → b` runs counter-clockwise round `i`)"),
    ("J_BY", "m", "`b`, y"),
    ("J_L0", "m", "rest distance of the two centres (great circle)"),
    ("J_W", "m", "joint length `w = |b - a|` (0 for coincident ends)"),
    ("J_K", "Pa", "effective stiffness `K` of eq. 9: traction per unit length and displacement"),
    ("J_MEFF", "kg", "reduced mass"),
    ("J_VAX", "m/s", "velocity of `j` relative to `i` at end `a`, x"),
    ("J_VAY", "m/s", "same, y"),
    ("J_VBX", "m/s", "velocity of `j` relative to `i` at end `b`, x"),
    ("J_VBY", "m/s", "same, y"),
    ("J_HI", "m", "thickness of `i`"),
    ("J_HJ", "m", "thickness of `j`"),
    ("J_EI", "Pa", "Young's modulus of `i`"),
    ("J_EJ", "Pa", "Young's modulus of `j`"),
    ("J_NU", "1", "Poisson's ratio (of `i`'s material)"),
    ("J_DT", "s", "time step"),
    ("J_DTM", "s/kg", ("the step over the joint's damping mass, `dt / m_d` (0: no bound); a "
                      "damper `c` acts as `step_damper(c, g[J_DTM])`")),
)
#: what an evaluator writes to ``out`` (zeroed by the engine before every call); the entries
#: are ``OUT_FX``, ``OUT_FY``, ``OUT_COUPLE``, ``OUT_BREAK``
OUT_LAYOUT = (
    ("out[0]", "N", "force on `j`, x (`i`'s frame); `i` gets the opposite"),
    ("out[1]", "N", "force on `j`, y"),
    ("out[2]", "N m", ("couple on `j` about the local vertical, counter-clockwise positive; `i` "
                      "gets the opposite")),
    ("out[3]", "1", ("joint evaluators: 0 while the joint holds, else its break mode "
                    "(`BREAK_*`); the joint then carries no force from this step on. "
                    "Collision evaluators: 1 when a plastic limit capped the normal force "
                    "(the `ridging` law), else 0; kept per pair only when a component asks "
                    "(`ContactModel.keep_caps`)")),
)


def layout_table(layout: tuple) -> str:
    """A layout as a Markdown table: index, name, unit, meaning."""
    if all(name.startswith("out[") for name, _, _ in layout):
        rows = ["| entry | unit | meaning |", "|---|---|---|"]
        rows += [f"| `{name}` | {unit} | {meaning} |" for name, unit, meaning in layout]
    else:
        rows = ["| index | name | unit | meaning |", "|---|---|---|---|"]
        rows += [f"| {k} | `{name}` | {unit} | {meaning} |"
                 for k, (name, unit, meaning) in enumerate(layout)]
    return "\n".join(rows)


# ---------------------------------------------------------------------- break modes
class BreakMode(IntEnum):
    """Why a joint broke: what a joint evaluator writes to ``out[OUT_BREAK]`` (any non-zero
    value breaks it) and what the engine records with the break (int8 codes in outputs)."""

    INTACT = 0  #: not broken
    STRAIN = 1  #: a strain or displacement threshold without a direction (the spring law)
    TENSION = 2  #: normal (opening) stress above the tensile strength
    SHEAR = 3  #: shear stress above the shear strength
    COMPRESSION = 4  #: normal (closing) stress above the compressive strength
    EXTERNAL = 5  #: broken by a component outside the law, without a more precise mode
    FLEXURE = 6  #: flexural (bending) strain above the critical strain (wave-induced)
    MELT = 7  #: one of its elements melted away (a process, ``siku_core.ice``)


# the same codes as plain ints, for compiled evaluators (numba stores an int in a float array;
# it cannot store an IntEnum member)
BREAK_STRAIN = int(BreakMode.STRAIN)
BREAK_TENSION = int(BreakMode.TENSION)
BREAK_SHEAR = int(BreakMode.SHEAR)
BREAK_COMPRESSION = int(BreakMode.COMPRESSION)
BREAK_EXTERNAL = int(BreakMode.EXTERNAL)
BREAK_FLEXURE = int(BreakMode.FLEXURE)
BREAK_MELT = int(BreakMode.MELT)
#: names of the break modes by code (code 0: intact), as written in output files
BREAK_MODES = {int(m): m.name.lower() for m in BreakMode}
#: what each break mode means (the reference tables of the documentation are made from it)
BREAK_MODE_MEANINGS = {
    BreakMode.INTACT: "not broken",
    BreakMode.STRAIN: "a strain or displacement threshold without a direction",
    BreakMode.TENSION: "normal (opening) stress above the tensile strength",
    BreakMode.SHEAR: "shear stress above the shear strength",
    BreakMode.COMPRESSION: "normal (closing) stress above the compressive strength",
    BreakMode.EXTERNAL: "broken by a component outside the law (`ctx.contacts.break_joints`)",
    BreakMode.FLEXURE: "flexural (bending) strain above the critical strain (wave-induced)",
    BreakMode.MELT: "one of its elements melted away (a process, `siku_core.ice`)",
}


# ---------------------------------------------------------------------- parameters
class ParameterRecord:
    """The parameter vector ``pars`` of one evaluator, declared once by name.

    ``ParameterRecord("sqrt_area", "damping_ratio")`` packs ``[values["sqrt_area"],
    values["damping_ratio"]]`` as float64 (:meth:`pack`) and gives the evaluator the index of
    each name as an attribute of :attr:`index`, a namedtuple instance: held in a module global
    (``P = RECORD.index``), ``pars[P.damping_ratio]`` is indexing with a compile-time constant
    in numba, as fast as a literal.
    """

    def __init__(self, *names: str):
        if len(set(names)) != len(names) or not all(n.isidentifier() for n in names):
            raise ValueError(f"parameter record names must be distinct identifiers: {names}")
        self.names: tuple[str, ...] = tuple(names)
        self.index = namedtuple("ParameterIndex", self.names)(*range(len(self.names)))

    def __len__(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        return f"ParameterRecord{self.names!r}"

    def pack(self, values: Mapping[str, Any]) -> np.ndarray:
        """The float64 vector of ``values[name]`` for every name, in order."""
        return np.array([float(values[n]) for n in self.names], dtype=np.float64)


# ---------------------------------------------------------------------- the law
class ContactLaw(Component):
    """Pair interaction: forces and torques between two elements, with per-joint history.

    A law supplies ``@njit`` evaluators of one contact (layouts: :mod:`siku_core.contact_law`):

    * ``collision_evaluator(g, pars, out)``: overlapping pairs (every law has one: a broken or
      absent joint continues as a collision contact); ``collision_evaluator(g, pars, hist,
      out)`` for a law that declares ``contact_history_names``: ``hist`` is the contact's row
      of those columns, which the evaluator may update (zero when the pair comes into contact,
      kept while it stays in contact, dropped when it separates);
    * ``joint_evaluator(g, pars, hist, out)``: intact frozen joints (laws with
      ``uses_joints = True``), updating the joint's ``hist`` row (``history_names`` columns).

    ``collision_record`` / ``joint_record`` (:class:`ParameterRecord`) name the entries of the
    float64 ``pars`` vectors passed to them; the engine packs them from
    :meth:`parameter_values` (the law's parameters ``self.p``, plus any values a law derives
    from them) through ``collision_parameters()`` / ``joint_parameters()`` (parameters are
    arguments, never compiled-in globals). The evaluators are read from the class without
    binding (an ``@njit`` function held as a class attribute binds like a method on an
    instance). ``history_update`` says how the history changes: ``"state"`` (a function of the
    geometry the joint has seen: maxima, failure flags, damage) or ``"rate"`` (integrated over
    the time step). A law may declare ``joint_energy(g, pars, hist)`` [J], the joint's stored
    elastic energy, which the conformance suite checks the force against. Guide:
    ``docs/howto/contact_laws.md``.
    """

    kind = "contact_law"
    #: whether the law has frozen joints (and so a ``joint_evaluator``)
    uses_joints: ClassVar[bool] = False
    #: columns of each joint's history row (``hist`` of the joint evaluator)
    history_names: ClassVar[tuple[str, ...]] = ()
    #: how the joint history changes: ``"state"`` (a function of the geometry the joint has
    #: seen) or ``"rate"`` (integrated over the step)
    history_update: ClassVar[str] = "state"
    #: columns of the per-contact history row of the collision evaluator (``()``: none, and the
    #: evaluator takes ``(g, pars, out)``)
    contact_history_names: ClassVar[tuple[str, ...]] = ()
    #: names of the collision evaluator's ``pars`` entries (``None``: no parameters)
    collision_record: ClassVar[ParameterRecord | None] = None
    #: names of the joint evaluator's ``pars`` entries (``None``: no parameters)
    joint_record: ClassVar[ParameterRecord | None] = None
    #: the collision evaluator, an ``@njit`` function ``(g, pars, out)`` (``(g, pars, hist,
    #: out)`` with ``contact_history_names``): every law defines one (``None`` here: a law
    #: without one is refused when it registers)
    collision_evaluator: ClassVar[Any] = None
    #: the joint evaluator, an ``@njit`` function ``(g, pars, hist, out)``, of a law with
    #: ``uses_joints = True`` (``None``: none, a law without joints)
    joint_evaluator: ClassVar[Any] = None
    #: the joint's stored elastic energy [J], an optional ``@njit`` function ``(g, pars,
    #: hist)`` the conformance suite checks the joint force against (``None``: not declared,
    #: the check is passed by)
    joint_energy: ClassVar[Any] = None
    required: ClassVar[Mapping[str, tuple[str, ...]]] = {
        "collision_parameters": (), "joint_parameters": ()}
    #: whether the law's dampers act through :func:`siku_core.contact.damping.step_damper` with the
    #: engine's ``g[J_DTM]`` / ``g[G_DTM]``: they cannot destabilise the step, and the
    #: stable-step estimate counts them bounded (``False``: explicit dampers, which lower it).
    #: Not inherited: read from the class's own namespace (a subclass with its own evaluator
    #: declares it again)
    bounded_damping: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A law written for siku 0.1 defines ``collision_parameters(self, sim)`` or
        ``joint_parameters(self, sim)``: it is adapted to the reference form (``sim`` is
        ``None``), with a deprecation warning (:func:`_without_sim`)."""
        super().__init_subclass__(**kwargs)
        for method in ("collision_parameters", "joint_parameters"):
            fn = cls.__dict__.get(method)
            if inspect.isfunction(fn) and list(inspect.signature(fn).parameters)[1:] == ["sim"]:
                setattr(cls, method, _without_sim(cls, method, fn))

    def parameter_values(self) -> Mapping[str, Any]:
        """The values the records are packed from: the law's parameters; a law whose
        evaluator takes a value derived from them (``tan(phi)`` of an angle) adds it here."""
        return self.p

    def collision_parameters(self) -> np.ndarray:
        """Parameter vector of the collision evaluator (``collision_record`` packed)."""
        rec = self.collision_record
        return rec.pack(self.parameter_values()) if rec is not None else np.zeros(0)

    def joint_parameters(self) -> np.ndarray:
        """Parameter vector of the joint evaluator (``joint_record`` packed)."""
        rec = self.joint_record
        return rec.pack(self.parameter_values()) if rec is not None else np.zeros(0)

    def stiffness_factor(self) -> float:
        """Joint stiffness per unit length relative to ``K`` of eq. 9 (for the dt estimate)."""
        return 1.0

    def stability_rates(self) -> dict[str, Any]:
        """What the engine's stable-step estimate (``siku_core.contact.stable_step``) needs of the
        law:
        ``joint_stiffness`` (:meth:`stiffness_factor`), ``joint_shear`` (the joint's stiffness
        along it relative to across it: a number, or ``"poisson"`` for ``1/(2(1 + nu))``),
        ``joint_damping`` (share of critical damping of a joint on its reduced mass, for its
        normal stiffness), ``joint_shear_damping`` (``"normal"``: the same damper along the
        joint, or ``"own"``: a share of critical of the shear stiffness),
        ``collision_stiffness`` (the collision's normal stiffness per unit contact width
        relative to ``K``), ``collision_damping`` (its share of critical damping) and
        ``unbounded`` (a reason the estimate cannot bound the law's stiffness, or ``None``) and
        ``bounded_damping`` (the class attribute :attr:`bounded_damping`).
        The default reads the built-in laws' parameter names (``joint_damping_ratio``,
        ``damping_ratio``, ``sqrt_area``); a law that damps or stiffens otherwise
        overrides it, or the estimate misses its damping."""
        p = self.p
        return {
            "joint_stiffness": self.stiffness_factor(),
            "joint_shear": 1.0,
            "joint_shear_damping": "normal",
            "joint_damping": float(p.get("joint_damping_ratio", 0.0)) if self.uses_joints
            else 0.0,
            "collision_stiffness": 1.0,
            "collision_damping": float(p.get("damping_ratio", 0.0)),
            # declared by the class itself: a subclass that brings its own evaluator says
            # again whether its dampers are bounded
            "bounded_damping": bool(type(self).__dict__.get("bounded_damping", False)),
            "unbounded": ("the sqrt_area collision stiffness K w sqrt(A_min / A) / 2 grows "
                          "without bound as the overlap A vanishes; taken as K w"
                          if p.get("sqrt_area", False) else None),
        }


def _without_sim(cls: type, method: str, fn: Any) -> Any:
    """``method(self, sim)``, the form of siku 0.1, as ``method(self)``: called with ``sim =
    None`` (a law that reads the simulation there must move that to ``setup(ctx)``); warns once,
    when the class is defined (:func:`siku_core.deprecation.warn_deprecated`)."""
    which = method.split("_")[0]
    warn_deprecated(
        f"{cls.__module__}.{cls.__qualname__}.{method}(self, sim)",
        f"define {method}(self), which reads the parameters from self.p, or declare "
        f"{which}_record (siku_core.contact_law.ParameterRecord) and no method; siku calls the "
        "old form with sim=None", stacklevel=4)  # past ABCMeta.__new__ to the class statement

    def adapted(self: Any) -> np.ndarray:
        return fn(self, None)

    adapted.__name__, adapted.__qualname__ = method, f"{cls.__qualname__}.{method}"
    adapted.__doc__ = fn.__doc__
    return adapted


# ---------------------------------------------------------------------- checks
#: evaluator attributes of a contact law and their reference parameters
EVALUATORS = {
    "collision_evaluator": ("g", "pars", "out"),
    "joint_evaluator": ("g", "pars", "hist", "out"),
}
#: the collision evaluator's parameters for a law with ``contact_history_names``
COLLISION_WITH_HISTORY = ("g", "pars", "hist", "out")


def evaluator_parameters(cls: Any, attr: str) -> tuple[str, ...]:
    """The reference parameters of evaluator ``attr`` of law class ``cls`` (the collision
    evaluator takes a history row when the law declares ``contact_history_names``)."""
    if attr == "collision_evaluator" and cls.contact_history_names:
        return COLLISION_WITH_HISTORY
    return EVALUATORS[attr]


def _check_names(head: str, attr: str, names: Any) -> None:
    """``names`` (``history_names``, ``contact_history_names``) is a tuple of distinct
    strings."""
    if not (isinstance(names, tuple) and all(isinstance(n, str) for n in names)):
        raise PluginError(f"{head}: {attr} is {names!r}, not a tuple of strings")
    if len(set(names)) != len(names):
        raise PluginError(f"{head}: {attr} {names!r} names a column twice")


def law_head(cls: type, package: str) -> str:
    """How messages name a law: ``contact law 'NAME' from package 'PKG'``."""
    return f"contact law '{cls.name}' from package '{package}'"


def check_contact_law(cls: Any, package: str) -> None:
    """A contact law's evaluators are present, jitted, and take the reference parameters; its
    records are :class:`ParameterRecord`; its ``history_names`` and ``contact_history_names``
    are tuples of distinct strings (at registration)."""
    head = law_head(cls, package)
    _check_names(head, "contact_history_names", cls.contact_history_names)
    for attr in EVALUATORS:
        if attr == "joint_evaluator" and not cls.uses_joints:
            continue
        expected = evaluator_parameters(cls, attr)
        ev = cls.collision_evaluator if attr == "collision_evaluator" else cls.joint_evaluator
        if ev is None:
            hint = (" (reuse the built-in one by subclassing the law registered as "
                    "'collision': siku_core.plugins.get_registry().get('contact_law', 'collision'))"
                    if attr == "collision_evaluator"
                    else " (uses_joints = True asks for one)")
            raise PluginError(f"{head}: no {attr}{hint}")
        fn = getattr(ev, "py_func", None)
        if fn is None or not callable(ev) or not hasattr(ev, "compile"):
            raise PluginError(
                f"{head}: {attr} is {ev!r}, not a numba @njit function "
                f"({attr}({', '.join(expected)}) decorated with numba.njit)"
            )
        got = tuple(inspect.signature(fn).parameters)
        if len(got) != len(expected):
            why = (" (contact_history_names declares a per-contact history row)"
                   if expected is COLLISION_WITH_HISTORY else "")
            raise PluginError(
                f"{head}: {attr} {fn.__name__}({', '.join(got)}) takes {len(got)} "
                f"parameters, expected {len(expected)}: ({', '.join(expected)}){why}"
            )
    for attr, rec in (("collision_record", cls.collision_record),
                      ("joint_record", cls.joint_record)):
        if rec is not None and not isinstance(rec, ParameterRecord):
            raise PluginError(f"{head}: {attr} is {rec!r}, not a "
                              "siku_core.contact_law.ParameterRecord(name, ...)")
    _check_names(head, "history_names", cls.history_names)
    if cls.history_update not in ("state", "rate"):
        raise PluginError(f"{head}: history_update is {cls.history_update!r}; allowed: "
                          "'state', 'rate'")


def numba_reason(exc: BaseException) -> str:
    """The lines of a numba error that say what is wrong and where (its messages span dozens
    of lines with source excerpts and colour codes), as one line."""
    lines = [re.sub(r"\x1b\[[0-9;]*m", "", ln).strip() for ln in str(exc).splitlines()]
    skip = ("Failed in ", "During:", "File ", "^", "- Resolution failure", "Resolution failure")
    useful = [ln for ln in lines if ln and not ln.startswith(skip) and set(ln) != {"^"}]
    text = useful[0] if useful else (lines[0] if lines else type(exc).__name__)
    if text.endswith(":") and len(useful) > 1:
        text = f"{text} {useful[1]}"
    where = next((ln for ln in lines if ln.startswith("File ")), "")
    if where:
        text = f"{text} ({where.rstrip(':')})"
    return text if len(text) <= 300 else text[:297] + "..."


def evaluator_of(law: ContactLaw, attr: str):
    """The law's evaluator ``attr`` as the jitted function itself: an ``@njit`` function held
    as a class attribute binds like a method when read from an instance (``law.attr`` is a
    bound method), so it is looked up without binding."""
    ev = inspect.getattr_static(law, attr)
    return getattr(ev, "__func__", ev)  # a staticmethod wrapper


def compile_evaluators(law: ContactLaw, package: str) -> None:
    """Compile the law's evaluators for the arguments the engine passes (1-D C-contiguous
    float64 arrays); a law whose evaluator does not compile is refused with a one-line
    :class:`PluginError` naming the package, the law, the evaluator and numba's reason."""
    from numba import types

    for attr in EVALUATORS:
        if attr == "joint_evaluator" and not law.uses_joints:
            continue
        names = evaluator_parameters(type(law), attr)
        ev = evaluator_of(law, attr)
        if not getattr(ev, "_can_compile", True):  # explicit signatures: numba checks those
            continue
        try:
            ev.compile((types.float64[::1],) * len(names))
        except Exception as exc:  # noqa: BLE001 - numba raises many kinds
            raise PluginError(
                f"{law_head(type(law), package)}: {attr} {ev.__name__}({', '.join(names)}) "
                f"does not compile for float64 arrays: {numba_reason(exc)}"
            ) from None


def parameter_vector(law: ContactLaw, which: str, package: str) -> np.ndarray:
    """``law.collision_parameters()`` (``which = "collision"``) or ``joint_parameters()`` as a
    C-contiguous float64 vector; anything else is a one-line :class:`PluginError`."""
    method = f"{which}_parameters"
    try:
        vec = np.ascontiguousarray(getattr(law, method)(), dtype=float)
        ok = vec.ndim == 1 and bool(np.isfinite(vec).all())
    except (TypeError, ValueError, KeyError) as exc:
        vec, ok = None, exc
    if ok is not True:
        raise PluginError(
            f"{law_head(type(law), package)}: {method}() must return a 1-D vector of finite "
            f"numbers; got {vec if vec is not None else ok!r}"
        )
    return vec


#: the contract a contact law is written against (docs/reference/api.md)
__all__ = [
    "ContactLaw", "ParameterRecord", "BreakMode", "BREAK_MODES", "BREAK_MODE_MEANINGS",
    "BREAK_STRAIN", "BREAK_TENSION",
    "BREAK_SHEAR", "BREAK_COMPRESSION", "BREAK_EXTERNAL", "BREAK_FLEXURE", "BREAK_MELT",
    "G_AREA", "G_CX", "G_CY", "G_NX", "G_NY", "G_WIDTH", "G_K", "G_MEFF", "G_VX", "G_VY",
    "G_AREA_I", "G_AREA_J", "G_HI", "G_HJ", "G_SIZE",
    "J_S1X", "J_S1Y", "J_S2X", "J_S2Y", "J_AX", "J_AY", "J_BX", "J_BY", "J_L0", "J_W", "J_K",
    "J_MEFF", "J_VAX", "J_VAY", "J_VBX", "J_VBY", "J_HI", "J_HJ", "J_EI", "J_EJ", "J_NU", "J_DT",
    "J_SIZE", "OUT_FX", "OUT_FY", "OUT_COUPLE", "OUT_BREAK", "OUT_SIZE",
    "COLLISION_LAYOUT", "JOINT_LAYOUT", "OUT_LAYOUT", "layout_table", "EVALUATORS",
    "check_contact_law",
]
