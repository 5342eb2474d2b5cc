"""The contacts view (``ctx.contacts``, :mod:`siku_core.contact.contacts_view`): plugins read the
joint
and pair tables through it, read only, and change contacts only through its actions; the
upper packages read nothing else of the contact model; the old reads of the model's internals
still work, with a warning naming the member to use."""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from siku_core.contact_law import BREAK_MODES, BreakMode
from siku_core.contact.contacts_view import MEMBERS, RENAMED, ContactsView
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text

ROOT = Path(__file__).resolve().parents[1]
UPPER = ("siku_plugins", "siku_forcing", "siku_io")
#: receivers of ``.contacts`` that are a component's context (their ``contacts`` is the view)
CONTEXTS = {"ctx", "context"}
#: calls that may take the view itself (others get its arrays or values)
ALLOWED_CALLS = {"getattr", "hasattr", "isinstance", "len", "repr", "id"}

SIZE = 2000.0  # m, the elements' side
DLON = math.degrees(SIZE / 6371000.0) / math.cos(math.radians(80.0))


# ---------------------------------------------------------------------- the scan of the code
def _name(node: ast.AST) -> str | None:
    """The last name of a ``Name`` or ``Attribute`` (``a.b.c`` -> ``c``)."""
    return node.id if isinstance(node, ast.Name) else (
        node.attr if isinstance(node, ast.Attribute) else None)


class _Scan:
    """Where the contacts flow in a set of modules: the names and attributes bound to them
    (from ``X.contacts``, by assignment, unpacking, ``self.cm = cm``, or as an argument of a
    function of the same module), and the reads of them that are not view members."""

    def __init__(self, sources: dict[str, str]):
        self.trees = {path: ast.parse(text) for path, text in sources.items()}
        self.names: dict[str, set[str]] = {p: set() for p in self.trees}
        self.attrs: set[str] = set()
        self.functions = {p: self._functions(t) for p, t in self.trees.items()}
        changed = True
        while changed:  # to a fixed point: a name bound from a bound name, and so on
            changed = any([self._bind(p, t) for p, t in self.trees.items()])

    @staticmethod
    def _functions(tree) -> dict[str, list[list[str]]]:
        out: dict[str, list[list[str]]] = {}
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                out.setdefault(node.name, []).append([a.arg for a in node.args.args])
        return out

    def holds(self, path: str, node: ast.AST) -> bool:
        """Whether ``node`` (an expression of module ``path``) is the contacts object."""
        if isinstance(node, ast.Attribute):
            return node.attr == "contacts" or node.attr in self.attrs
        if isinstance(node, ast.Name):
            return node.id in self.names[path]
        if isinstance(node, ast.IfExp):
            return self.holds(path, node.body) or self.holds(path, node.orelse)
        if isinstance(node, ast.BoolOp):
            return any(self.holds(path, v) for v in node.values)
        if isinstance(node, ast.NamedExpr):
            return self.holds(path, node.value)
        if isinstance(node, ast.Call) and _name(node.func) == "getattr" and len(node.args) > 1:
            a = node.args[1]
            return isinstance(a, ast.Constant) and a.value == "contacts"
        return False

    def _mark(self, path: str, target: ast.AST) -> bool:
        if isinstance(target, ast.Name) and target.id not in self.names[path]:
            self.names[path].add(target.id)
            return True
        if isinstance(target, ast.Attribute) and target.attr not in self.attrs:
            self.attrs.add(target.attr)
            return True
        return False

    def _bind(self, path: str, tree) -> bool:
        changed = False
        for node in ast.walk(tree):
            pairs: list[tuple[ast.AST, ast.AST]] = []
            if isinstance(node, ast.Assign):
                for t in node.targets:
                    if isinstance(t, (ast.Tuple, ast.List)) and isinstance(
                            node.value, (ast.Tuple, ast.List)) and len(t.elts) == len(
                            node.value.elts):
                        pairs += list(zip(t.elts, node.value.elts))
                    else:
                        pairs.append((t, node.value))
            elif isinstance(node, (ast.AnnAssign, ast.NamedExpr)) and node.value is not None:
                pairs.append((node.target, node.value))
            elif isinstance(node, ast.Call):  # a function of the module handed the contacts
                called = self.functions[path].get(_name(node.func) or "", [])
                for a, arg in enumerate(node.args):
                    if self.holds(path, arg):
                        for params in called:
                            skip = 1 if params[:1] == ["self"] else 0
                            if a + skip < len(params):
                                pairs.append((ast.Name(params[a + skip]), arg))
            for target, value in pairs:
                if self.holds(path, value):
                    changed |= self._mark(path, target)
        return changed

    def faults(self) -> list[str]:
        """``path:line: what`` for every read of the contacts that is not a view member."""
        out = []
        for path, tree in self.trees.items():
            local = self.functions[path]
            for node in ast.walk(tree):
                where = f"{path}:{getattr(node, 'lineno', '?')}"
                if isinstance(node, ast.Attribute) and node.attr == "contacts":
                    if _name(node.value) not in CONTEXTS:
                        out.append(f"{where}: {ast.unparse(node)} is the contact model; read "
                                   "ctx.contacts (or sim.context.contacts)")
                if isinstance(node, ast.Attribute) and self.holds(path, node.value) \
                        and node.attr not in MEMBERS:
                    out.append(f"{where}: {ast.unparse(node)} is no member of ContactsView")
                if not isinstance(node, ast.Call):
                    continue
                fn = _name(node.func)
                if fn in ("getattr", "hasattr", "setattr", "delattr") and node.args \
                        and self.holds(path, node.args[0]):
                    a = node.args[1] if len(node.args) > 1 else None
                    if fn != "getattr" or not (isinstance(a, ast.Constant)
                                               and a.value in MEMBERS):
                        out.append(f"{where}: {ast.unparse(node)} reads past ContactsView")
                elif fn not in ALLOWED_CALLS and fn not in local:
                    for arg in [*node.args, *(k.value for k in node.keywords)]:
                        if self.holds(path, arg):
                            out.append(f"{where}: {ast.unparse(node)} hands the contacts to "
                                       "code outside the module")
        return out


def upper_sources() -> dict[str, str]:
    return {str(p.relative_to(ROOT)): p.read_text(encoding="utf-8")
            for pkg in UPPER for p in sorted((ROOT / pkg).rglob("*.py"))}


def test_upper_packages_read_contacts_only_through_the_view():
    """No module of siku_plugins, siku_forcing or siku_io reads the contact model: every
    ``.contacts`` is a context's, and every read of what it gives is a ContactsView member."""
    sources = upper_sources()
    assert len(sources) > 50
    scan = _Scan(sources)
    assert scan.faults() == []
    # the scan saw the readers: the processes, the wave breaking, the writer, the lab
    seen = {p for p, names in scan.names.items() if names}
    for path in ("siku_plugins/processes/ridging.py", "siku_plugins/processes/refreeze.py",
                 "siku_forcing/waves/wave_breaking.py", "siku_plugins/lab.py",
                 "siku_plugins/floating/bending.py", "siku_io/output/hdf5.py"):
        assert path in seen, path
    assert "cm" in scan.attrs  # ``self.cm = cm`` of the bending beams and the wave breaking


def test_upper_packages_import_no_module_of_the_contact_model():
    """Nor do they import the model's modules (``ContactModel``, its ``JointBook``)."""
    model = {"siku_core.contact.contact_model", "siku_core.contact.contact_joints"}
    bad = []
    for path, text in upper_sources().items():
        for node in ast.walk(ast.parse(text)):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [f"{path}:{node.lineno}: {n}" for n in names if n in model]
    assert bad == []


def test_the_scan_finds_every_way_past_the_view():
    """The scan is not vacuous: each way of reaching the model's internals in a module is
    found (through a name, an unpacked name, an attribute of another object, a helper's
    parameter, ``getattr``, a simulation's ``contacts``, an engine function handed the view),
    and view members are not."""
    bad = '''
def a(ctx):
    cm = ctx.contacts
    return cm.jK, cm.intact

def b(ctx):
    st, c = ctx.state, ctx.contacts
    return c.poff

class C:
    def __init__(self, ctx):
        self.cm = ctx.contacts

    def go(self, other):
        return self.cm.hist, other.cm.pairs

def d(ctx):
    return getattr(ctx.contacts, "law", None), getattr(ctx.contacts, "law_params")

def e(ctx, t):
    _helper(ctx.contacts, t)

def _helper(m, t):
    return m.n_overlap

def f(sim):
    return sim.contacts.ji

def g(ctx):
    from siku_core.contact.contact_overlaps import contact_lines
    return contact_lines(ctx.contacts, [0])
'''
    faults = _Scan({"m.py": bad}).faults()
    got = sorted(f.split(":")[1] + " " + f.split(": ", 1)[1].split(" ")[0] for f in faults)
    assert got == sorted(["4 cm.jK", "8 c.poff", "15 self.cm.hist", "18 getattr(ctx.contacts,",
                          "24 m.n_overlap", "27 sim.contacts",
                          "31 contact_lines(ctx.contacts,"]), faults


def test_every_model_rename_names_a_member():
    """The deprecation messages name view members (or the context's ``radius``)."""
    for old, new in RENAMED.items():
        for member in new.replace(" or ", ", ").split(", "):
            assert member in MEMBERS or member == "ctx.radius", (old, member)


# ---------------------------------------------------------------------- the view of a run
def jointed_row(steps: int = 4) -> Simulation:
    """Three 2 km elements in a row at 80°N jointed along their shared edges (distributed
    springs), the middle one pushed east at 1 cm/s, with ``refreeze``'s weld (joint slots)."""
    els = [{"center": (k * DLON, 80.0), "thickness": 1.0,
            **({"velocity": (0.01, 0.0)} if k == 1 else {})} for k in range(3)]
    text = scene_text(els, size=SIZE, dt=0.25, duration=steps * 0.25, extra=(
        '[contact]\nlaw = "distributed_spring"\njoints = "pairs"\npairs = [[0, 1], [1, 2]]\n'
        'params = { tensile_strain = 1.0 }\n\n[[process]]\nname = "refreeze"\n'
        'params = { weld = true, weld_time = 1e6 }\n'))
    return Simulation(scene_from_text(text, "<row>"), out=False, progress=False)


@pytest.fixture(scope="module")
def row():
    sim = jointed_row()
    sim.run()
    return sim


def test_context_gives_the_view_and_none_without_contacts(row):
    view = row.context.contacts
    assert isinstance(view, ContactsView) and row.context.contacts is view
    assert view.views(row.contacts)
    plain = Simulation(scene_from_text(scene_text([(0.0, 80.0)], dt=60.0, duration=60.0),
                                       "<one>"), out=False, progress=False)
    assert plain.context.contacts is None


def test_tables_are_the_models_arrays_read_only(row):
    """Each array member holds the model's current values and cannot be written through."""
    view, cm = row.context.contacts, row.contacts
    same = {"ji": cm.ji, "jj": cm.jj, "ends_i": cm.ends_i, "ends_j": cm.ends_j,
            "width": cm.width, "rest_distance": cm.L0, "intact": cm.intact,
            "break_mode": cm.break_mode, "break_time": cm.break_time, "joint_history": cm.hist,
            "joint_stiffness": cm.jK, "joint_reduced_mass": cm.jmeff, "pairs": cm.pairs,
            "pair_active": cm.pair_active, "pair_capped": cm.pair_capped,
            "pair_offsets": cm.poff, "pair_index": cm.pidx, "youngs_modulus": cm.E,
            "poisson_ratio": cm.nu}
    for name, want in same.items():
        got = getattr(view, name)
        assert np.shares_memory(got, want) or not want.size, name
        assert np.array_equal(got, want, equal_nan=True), name
        assert not got.flags.writeable, name
        with pytest.raises(ValueError):
            got[...] = 0
    assert view.n_joints == 2 and view.n_intact == 2 and view.joint_slots == 5
    assert view.n_pairs == len(cm.pairs) and view.n_overlapping == cm.n_overlap
    assert view.law_name == "distributed_spring" and view.law_uses_joints
    assert view.law_params["tensile_strain"] == 1.0
    with pytest.raises(TypeError):
        view.law_params["tensile_strain"] = 2.0
    with pytest.raises(AttributeError):
        view.intact = np.zeros(2, bool)


def test_actions_change_the_joints_and_the_tables_follow():
    """Breaking a joint, refreezing it and creating one go through to the model, and the
    view's arrays show the new state (views of the arrays the model holds now)."""
    sim = jointed_row(steps=1)
    sim.run()
    view = sim.context.contacts
    assert view.break_joints(np.array([1]), BreakMode.TENSION, sim.time) == 1
    assert view.intact.tolist() == [True, False]
    assert BREAK_MODES[int(view.break_mode[1])] == "tension"
    assert view.break_time[1] == sim.time
    rows = view.take_breaks()
    assert rows["joint"].tolist() == [1] and view.take_breaks()["joint"].tolist() == []
    assert view.refreeze_joints(np.array([1]), sim.time) == 1
    assert view.intact.all() and view.n_intact == 2
    # refrozen at rest where its sides are: no gap (to round-off of the frames, ~1e-9 m)
    assert float(view.joint_gaps(np.array([1]))[0]) < 1e-9 * SIZE
    line = np.array([[[-0.5 * SIZE, 0.5 * SIZE], [-0.5 * SIZE, -0.5 * SIZE]]])
    new = view.create_joints(np.array([[0, 2]]), line)
    assert new.tolist() == [2] and view.n_joints == 3 and len(view.ji) == 3
    assert (view.ji[2], view.jj[2]) == (0, 2) and view.width[2] == pytest.approx(SIZE)
    view.keep_caps()
    assert len(view.pair_capped) == view.n_pairs
    count, label = view.floe_labels()
    assert count == 1 and label.tolist() == [0, 0, 0]


def test_old_reads_of_the_model_warn_and_name_the_member(row):
    """``ctx.contacts.<internal>`` still reads the model, with a DeprecationWarning that names
    the view's member; a name neither has is an AttributeError."""
    view, cm = row.context.contacts, row.contacts
    with pytest.warns(DeprecationWarning, match="youngs_modulus"):
        assert view.E is cm.E
    with pytest.warns(DeprecationWarning, match="joint_stiffness"):
        assert np.array_equal(view.jK, cm.jK)
    with pytest.warns(DeprecationWarning, match="has no member for it"):
        assert view.rm is cm.rm
    with pytest.raises(AttributeError, match="no member 'nonsense'"):
        view.nonsense  # noqa: B018
