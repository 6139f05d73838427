"""The plain-data wire: what a method's process may send a study, read back without pickle."""

import json
import pickle
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from droneplan.formulations.herding import Allocation
from droneplan.scenarios.shark.simulate import SharkCommand, SharkPhase
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies import wire

CAP = 1 << 20

plain_scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(allow_nan=False), st.text(max_size=20)
)
plain_arrays = hnp.arrays(
    dtype=st.sampled_from([np.float64, np.float32, np.int64, np.int8, np.uint16, np.bool_]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4),
)
plain = st.recursive(
    st.one_of(plain_scalars, plain_arrays),
    lambda children: st.one_of(
        st.lists(children, max_size=4),
        st.lists(children, max_size=4).map(tuple),
        st.dictionaries(st.text(max_size=8), children, max_size=4),
    ),
    max_leaves=20,
)


def _same(a, b):
    if isinstance(a, np.ndarray):
        return (
            isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and a.shape == b.shape
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        )
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


@settings(max_examples=150, deadline=None)
@given(plain)
def test_plain_values_round_trip(value):
    assert _same(value, wire.decode(wire.encode(value), max_bytes=CAP))


def test_non_finite_floats_and_numpy_scalars():
    out = wire.decode(
        wire.encode([float("nan"), float("inf"), np.float32(1.5), np.int64(3), np.bool_(True)]), max_bytes=CAP
    )
    assert np.isnan(out[0]) and out[1] == float("inf") and out[2:] == [1.5, 3, True]
    assert type(out[3]) is int and type(out[4]) is bool


def test_droneplan_result_types_round_trip():
    res = SolveResult(
        Status.OPTIMAL, objective=3.0, bound=3.0, x=np.arange(4.0).reshape(2, 2), info={"a": 1, "f": len}
    )
    back = wire.decode(wire.encode(res), max_bytes=CAP)
    assert isinstance(back, SolveResult) and back.status is Status.OPTIMAL and back.bound == 3.0
    assert np.array_equal(back.x, res.x) and dict(back.info) == {"a": 1}  # the function in info is dropped
    alloc = Allocation(
        target=np.array([1, 0]), direction=np.array([1, -1]), travel=np.ones(2), points=np.zeros(2)
    )
    assert np.array_equal(wire.decode(wire.encode(alloc), max_bytes=CAP).direction, [1, -1])
    cmd = wire.decode(wire.encode((SharkCommand(np.ones(3), False), SharkPhase.PURSUIT)), max_bytes=CAP)
    assert (
        isinstance(cmd[0], SharkCommand) and cmd[0].at_interception is False and cmd[1] is SharkPhase.PURSUIT
    )


class Evil:
    def __reduce__(self):
        return (print, ("this would run in the study",))


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (Evil(), "value: an object of type Evil"),
        ([1, {"k": Evil()}], "value[1]['k']: an object of type Evil"),
        (np.array([1 + 2j]), "dtype complex128"),
        (np.array(["1.5"]), "dtype <U3"),
        (np.array([object()], dtype=object), "dtype object"),
        ({1: 2}, "dict key of type int"),
        (1 + 2j, "object of type complex"),
        (b"raw", "object of type bytes"),
    ],
)
def test_everything_else_is_refused_naming_the_type(value, words):
    with pytest.raises(wire.NotPlainError, match=None) as info:
        wire.encode(value)
    assert words in str(info.value)
    refused = wire.decode(wire.refusal(info.value, value), max_bytes=CAP)
    assert isinstance(refused, wire.Refused) and words in refused.why


def test_too_deep_is_refused_both_ways():
    deep: list = []
    for _ in range(wire.MAX_DEPTH + 5):
        deep = [deep]
    with pytest.raises(wire.NotPlainError, match="deeper"):
        wire.encode(deep)
    doc = ("[" * 100_000 + "]" * 100_000).encode()
    with pytest.raises(wire.WireError):
        wire.decode(wire.MAGIC + struct.pack(">Q", len(doc)) + doc, max_bytes=1 << 30)


def _forged(doc, blob=b""):
    raw = json.dumps(doc).encode()
    return wire.MAGIC + struct.pack(">Q", len(raw)) + raw + blob


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (pickle.dumps(Evil()), "wrong magic"),
        (wire.MAGIC + struct.pack(">Q", 1000) + b"{}", "truncated"),
        (
            _forged({"$": "nd", "dtype": "<f8", "shape": [10], "off": 0, "n": 80}, b"x" * 8),
            "not in the message",
        ),
        (_forged({"$": "nd", "dtype": "|O", "shape": [1], "off": 0, "n": 8}, b"x" * 8), "dtype object"),
        (_forged({"$": "obj", "type": "os.system", "f": {}}), "unknown type"),
        (_forged({"$": "obj", "type": "SolveResult", "f": {"status": "optimal"}}), "cannot be built"),
        (_forged({"$": "enum", "type": "Status", "v": "proven-by-me"}), "not a Status"),
        (_forged({"k": 1}), "unknown node"),
        (_forged({"$": "pickle", "v": "gASV"}), "unknown node kind"),
    ],
)
def test_forged_or_garbage_messages_are_refused(data, words):
    with pytest.raises(wire.WireError, match=None) as info:
        wire.decode(data, max_bytes=CAP)
    assert words in str(info.value)


def test_the_cap_is_checked_before_parsing():
    msg = wire.encode(np.zeros(1000))
    assert wire.decode(msg, max_bytes=len(msg)).shape == (1000,)
    with pytest.raises(wire.WireError, match="more than the cap"):
        wire.decode(msg, max_bytes=len(msg) - 1)
