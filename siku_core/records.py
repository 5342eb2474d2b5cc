"""Named records: the bulk data handed to a compiled kernel as one argument.

A record type declares its fields once, by name, with each field's dtype kind and number of
dimensions and what it holds (units included)::

    JOINTS = record_type("JointTable", __name__, [
        ("ji", "i", 1, "first element of each joint"),
        ("L0", "f", 1, "rest length [m]"),
    ])

It is a :func:`collections.namedtuple` class, which numba takes as one argument: a kernel
reads ``jt.L0[k]``, the field found by name at compile time (an ``extractvalue`` of the
argument, as cheap as a positional argument: ``bench.phase`` measured no difference on the
contact loops), and passes the record on to the functions it calls. A kernel takes a handful
of records and scalars instead of a long positional list kept in order by hand; adding an
array touches the record's declaration and the code that builds the record (its producer), not
every signature between the producer and the loop that reads it. The arrays are the producer's
own (a record holds references, copies nothing): a kernel may write into them.

:class:`~siku_core.contact_law.ParameterRecord` is the same idea for a law's parameter vector
(scalars, packed into one float64 array whose indices numba folds to constants).

The engine's record types are declared next to their producers (the contact loops' element,
joint and pair tables and element-to-contact index: :mod:`siku_core.contact.contact_tables`); each
plugin declares its own beside the code that builds them (docs/explanation/design.md lists the
shipped ones). No compiled kernel takes more than 12 positional arguments
(``tests/test_kernel_args.py``).

At the boundary: numba's dispatcher types a plain tuple's fields in C but a namedtuple's in
Python, 2–5 µs more per record and call (measured on the contact loops' records, 6–16 fields).
On a kernel called every step of a small scene that is a tenth of the step (the 184-element
floe of ``bench.floating``: +15 µs of 150), so the step's entry points pass ``tuple(record)``
and the compiled entry names it again, ``el = ContactElements(*el_t)``, at no cost inside
(the contact loops, the gather; the floating step's kernels likewise).
"""
from __future__ import annotations

from collections import namedtuple
from collections.abc import Sequence
from typing import Any

import numpy as np

from .errors import SikuError

#: dtype kinds a field may declare (``numpy.dtype.kind``): signed and unsigned integers,
#: floats, booleans; ``"n"``: a Python or numpy number, not an array (``ndim`` 0)
FIELD_KINDS = "iufbn"


class RecordError(SikuError, TypeError):
    """A record built with a field of the wrong kind or number of dimensions."""


class Record(tuple):
    """Base of every record type (the methods; the fields are the namedtuple's)."""

    __slots__ = ()
    #: per field: ``(name, kind, ndim, description)``, in order
    fields: tuple[tuple[str, str, int, str], ...] = ()

    def check(self) -> Record:
        """This record, after checking that every field has its declared kind and number of
        dimensions (raises :class:`RecordError` naming the record and field); a test's check,
        not a hot path's (a mismatch compiles a new specialisation, it does not fail)."""
        for (name, kind, ndim, _), value in zip(self.fields, self):
            if kind == "n":
                ok = np.ndim(value) == 0 and np.asarray(value).dtype.kind in "iufb"
            else:
                ok = (isinstance(value, np.ndarray) and value.ndim == ndim
                      and value.dtype.kind == kind)
            if not ok:
                got = (f"{type(value).__name__} {getattr(value, 'dtype', '')}"
                       f" ndim={np.ndim(value)}")
                raise RecordError(f"{type(self).__name__}.{name}: expected kind {kind!r} with "
                                  f"ndim={ndim}, got {got}")
        return self

    @classmethod
    def describe(cls) -> str:
        """One line per field: name, kind, dimensions, description (the docs' table)."""
        return "\n".join(f"{n:14s} {k}{d}  {text}" for n, k, d, text in cls.fields)


def record_type(name: str, module: str, fields: Sequence[tuple[str, str, int, str]],
                doc: str = "") -> type[Any]:
    """A record type (a namedtuple class numba takes as one argument) named ``name``, held as
    the global ``name`` of ``module`` (so that numba's cache and pickling find it again).

    ``fields``: per field ``(name, kind, ndim, description)``; ``kind`` one of :data:`FIELD_KINDS`.
    """
    names = [f[0] for f in fields]
    if len(set(names)) != len(names) or not all(n.isidentifier() and not n.startswith("_")
                                                for n in names):
        raise ValueError(f"record {name}: field names must be distinct public identifiers")
    for f in fields:
        if len(f) != 4 or f[1] not in FIELD_KINDS or (f[1] == "n") != (f[2] == 0):
            raise ValueError(f"record {name}: bad field declaration {f!r}")
    base = namedtuple(name, names)  # noqa: PYI024 (numba types a namedtuple's fields by name)
    table = "\n".join(f"    {n:14s} {k}{d}  {text}" for n, k, d, text in fields)
    cls = type(name, (base, Record), {
        "__slots__": (), "__module__": module, "fields": tuple(tuple(f) for f in fields),
        "__doc__": f"{doc or 'Record ' + name + '.'}\n\nFields (name, kind and ndim, "
                   f"meaning)::\n\n{table}\n",
    })
    cls.__qualname__ = name
    return cls
