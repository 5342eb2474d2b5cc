"""Named records (siku_core.records): declared once, checked by kind and dimensions, taken by
numba as one argument whose fields a kernel reads by name."""
import numpy as np
import pytest
from numba import njit

from siku_core.records import RecordError, record_type

Pair = record_type("Pair", __name__, [
    ("a", "f", 1, "first values [m]"),
    ("k", "i", 1, "indices"),
    ("scale", "n", 0, "a scalar factor [1]"),
], doc="Two arrays and a scalar.")


@njit(cache=False)
def _weighted(rec):
    s = 0.0
    for i in range(rec.k.size):
        s += rec.a[rec.k[i]] * rec.scale
    return s


def test_fields_by_name_in_a_kernel():
    a = np.array([1.0, 2.0, 4.0])
    rec = Pair(a=a, k=np.array([2, 0]), scale=0.5).check()
    assert _weighted(rec) == (4.0 + 1.0) * 0.5
    assert rec.a is a  # holds the producer's array, copies nothing


def test_check_names_record_and_field():
    with pytest.raises(RecordError, match=r"Pair\.k: expected kind 'i' with ndim=1"):
        Pair(a=np.zeros(3), k=np.zeros(2), scale=1.0).check()
    with pytest.raises(RecordError, match=r"Pair\.scale"):
        Pair(a=np.zeros(3), k=np.zeros(2, dtype=np.int64), scale=np.zeros(2)).check()


def test_declaration_errors_and_docs():
    with pytest.raises(ValueError, match="distinct public identifiers"):
        record_type("Bad", __name__, [("x", "f", 1, ""), ("x", "f", 1, "")])
    with pytest.raises(ValueError, match="bad field declaration"):
        record_type("Bad", __name__, [("x", "n", 1, "")])
    assert "a scalar factor [1]" in Pair.describe() and "scale" in Pair.__doc__
