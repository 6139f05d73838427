"""Plain data across a process boundary, without pickle: what a user's method may send a study.

A study runs each method in a process of its own, and that process is the method's: it may write
any bytes at all to the pipe that carries its result back. So the study never unpickles them
(``pickle.loads`` runs whatever code the bytes name). What crosses is encoded by :func:`encode`
and read back by :func:`decode`, which builds nothing but plain values:

- ``None``, ``bool``, ``int``, ``float`` (NaN and inf included), ``str``;
- ``list``, ``tuple`` and ``dict`` with ``str`` keys, of plain values;
- numpy arrays of booleans, integers or reals (any shape; other dtypes are refused);
- numpy scalars, read back as the Python number;
- a closed set of droneplan's own result types, sent as their plain fields and rebuilt by their
  constructors: :class:`~droneplan.solvers.result.SolveResult` (its ``info`` keeps only plain
  entries) with its :class:`~droneplan.solvers.result.Status`, the herding
  :class:`~droneplan.formulations.herding.Allocation`, the shark
  :class:`~droneplan.formulations.shark.assignment.Assignment`, the closed-loop commands
  ``SharkCommand``, ``HerdingCommand``, ``CovertCommand`` and the phase enums ``SharkPhase``,
  ``HerdingPhase``, ``CovertPhase``.

Anything else makes :func:`encode` raise :class:`NotPlainError`, naming the type and where it sits
(``"x[2]: an object of type Foo"``). A method's process then sends :func:`refusal` instead, which
decodes to a :class:`Refused` that the study records as an ``invalid`` row.

The format: the magic ``b"DPW1"``, the length of a JSON document (8 bytes, big-endian), the
document, then the raw bytes of the arrays it refers to (each node names its offset and size).
:func:`decode` refuses input beyond ``max_bytes`` before it parses anything, a document nested
deeper than :data:`MAX_DEPTH`, arrays whose bytes lie outside the buffer, and every node it does
not know, with a one-line :class:`WireError`.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import struct
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = [
    "MAX_DEPTH",
    "NotPlainError",
    "Refused",
    "WireError",
    "decode",
    "encode",
    "is_registered",
    "phase_types",
    "refusal",
]

MAGIC = b"DPW1"
_LENGTH = struct.Struct(">Q")
MAX_DEPTH = 64
"""Deepest nesting of lists, tuples, dicts and result types that :func:`encode`/:func:`decode` accept."""
_ARRAY_KINDS = "biuf"  # bool, signed and unsigned integers, reals
_TAG = "$"


class WireError(ValueError):
    """Bytes that are not a well-formed plain-data message (one line)."""


class NotPlainError(TypeError):
    """A value that is not plain data (its message names the type and where it sits)."""


@dataclasses.dataclass(frozen=True)
class Refused:
    """What a method's process sends when the method returned something that is not plain data."""

    type_name: str
    """The offending type's name (``"Foo"``)."""
    why: str
    """Where it sat and what it was (``"x[2]: an object of type Foo"``)."""


# --------------------------------------------------------------------------- the closed set
def _registry() -> dict[str, type]:
    """Tag -> droneplan result type (imported on first use: some of them load solver libraries)."""
    from droneplan.formulations.herding import Allocation
    from droneplan.formulations.shark.assignment import Assignment
    from droneplan.scenarios.covert.dynamics import CovertCommand, CovertPhase
    from droneplan.scenarios.herding import HerdingCommand, HerdingPhase
    from droneplan.scenarios.shark.simulate import SharkCommand, SharkPhase
    from droneplan.solvers.result import SolveResult, Status

    return {
        "SolveResult": SolveResult,
        "Status": Status,
        "Allocation": Allocation,
        "Assignment": Assignment,
        "SharkCommand": SharkCommand,
        "HerdingCommand": HerdingCommand,
        "CovertCommand": CovertCommand,
        "SharkPhase": SharkPhase,
        "HerdingPhase": HerdingPhase,
        "CovertPhase": CovertPhase,
    }


_TYPES: dict[str, type] = {}


def _types() -> dict[str, type]:
    if not _TYPES:
        _TYPES.update(_registry())
    return _TYPES


def phase_types() -> tuple[type, ...]:
    """The closed-loop phase enums of the closed set (``SharkPhase``, ``HerdingPhase``, ``CovertPhase``)."""
    return tuple(_types()[name] for name in ("SharkPhase", "HerdingPhase", "CovertPhase"))


def is_registered(value: Any) -> bool:
    """Whether ``value``'s exact type is one of the closed set of droneplan result types."""
    return _tag_of(value) is not None


def _tag_of(value: Any) -> str | None:
    """The registry tag of ``value``'s exact type, or None."""
    for tag, cls in _types().items():
        if type(value) is cls:
            return tag
    return None


def _fields(value: Any) -> dict[str, Any]:
    if dataclasses.is_dataclass(value):
        return {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    return dict(value._asdict())  # the NamedTuple commands


# --------------------------------------------------------------------------- encoding
class _Encoder:
    def __init__(self) -> None:
        self.chunks: list[bytes] = []
        self.offset = 0

    def array(self, arr: np.ndarray, where: str) -> dict[str, Any]:
        if arr.dtype.kind not in _ARRAY_KINDS or arr.dtype.hasobject:
            raise NotPlainError(
                f"{where}: an array of dtype {arr.dtype} (plain arrays hold bools, ints or reals)"
            )
        data = np.ascontiguousarray(arr).astype(arr.dtype.newbyteorder("<"), copy=False).tobytes()
        node: dict[str, Any] = {_TAG: "nd", "dtype": arr.dtype.newbyteorder("<").str}
        node.update(shape=list(arr.shape), off=self.offset, n=len(data))
        self.chunks.append(data)
        self.offset += len(data)
        return node

    def node(self, value: Any, where: str, depth: int) -> Any:
        if depth > MAX_DEPTH:
            raise NotPlainError(f"{where}: nested deeper than {MAX_DEPTH} levels")
        if value is None or type(value) in (bool, str, int):
            return value
        if type(value) is float:
            return value if math.isfinite(value) else {_TAG: "float", "v": repr(value)}
        if isinstance(value, np.ndarray):
            return self.array(value, where)
        if isinstance(value, (np.bool_, np.integer, np.floating)):
            return self.node(value.item(), where, depth)
        tag = _tag_of(value)
        if tag is not None:
            return self.typed(tag, value, where, depth)
        return self.container(value, where, depth)

    def typed(self, tag: str, value: Any, where: str, depth: int) -> dict[str, Any]:
        if isinstance(value, enum.Enum):
            return {_TAG: "enum", "type": tag, "v": value.value}
        fields = _fields(value)
        if tag == "SolveResult":
            fields["info"] = _plain_entries(dict(fields["info"] or {}))
        return {
            _TAG: "obj",
            "type": tag,
            "f": {k: self.node(v, f"{where}.{k}", depth + 1) for k, v in fields.items()},
        }

    def container(self, value: Any, where: str, depth: int) -> Any:
        if type(value) in (list, tuple):
            items = [self.node(v, f"{where}[{i}]", depth + 1) for i, v in enumerate(value)]
            return items if type(value) is list else {_TAG: "tuple", "v": items}
        if type(value) is dict:
            for k in value:
                if type(k) is not str:
                    raise NotPlainError(f"{where}: a dict key of type {type(k).__name__} (keys must be str)")
            return {
                _TAG: "dict",
                "v": [[k, self.node(v, f"{where}[{k!r}]", depth + 1)] for k, v in value.items()],
            }
        raise NotPlainError(f"{where}: an object of type {type(value).__qualname__}")


def _plain_entries(info: dict[Any, Any]) -> dict[str, Any]:
    """The entries of a SolveResult's ``info`` that are plain data (the others are dropped)."""
    kept = {}
    for k, v in info.items():
        if type(k) is not str:
            continue
        try:
            _Encoder().node(v, k, 1)
        except NotPlainError:
            continue
        kept[k] = v
    return kept


def encode(value: Any) -> bytes:
    """The plain-data message of ``value`` (module docstring: what is plain); raises
    :class:`NotPlainError` naming the first part that is not."""
    enc = _Encoder()
    tree = enc.node(value, "value", 0)
    try:
        doc = json.dumps(tree, separators=(",", ":")).encode()
    except ValueError as exc:  # an int beyond Python's digit limit for str()
        raise NotPlainError(f"value: {' '.join(str(exc).split())[:120]}") from None
    return MAGIC + _LENGTH.pack(len(doc)) + doc + b"".join(enc.chunks)


def refusal(error: NotPlainError, value: Any) -> bytes:
    """The message that stands for a return value :func:`encode` refused."""
    why = str(error)
    return encode({_TAG + "refused": [type(value).__qualname__ if why.startswith("value:") else "", why]})


# --------------------------------------------------------------------------- decoding
class _Decoder:
    def __init__(self, blob: memoryview) -> None:
        self.blob = blob

    def array(self, node: dict[str, Any]) -> np.ndarray:
        try:
            dtype = np.dtype(str(node["dtype"]))
            shape = tuple(int(s) for s in node["shape"])
            off, n = int(node["off"]), int(node["n"])
        except (KeyError, TypeError, ValueError) as exc:
            raise WireError(f"a malformed array node ({type(exc).__name__})") from None
        if dtype.kind not in _ARRAY_KINDS or dtype.hasobject or dtype.fields is not None:
            raise WireError(f"an array of dtype {dtype} (plain arrays hold bools, ints or reals)")
        if any(s < 0 for s in shape) or len(shape) > MAX_DEPTH:
            raise WireError(f"an array of shape {shape}")
        if off < 0 or n < 0 or off + n > len(self.blob) or math.prod(shape) * dtype.itemsize != n:
            raise WireError(
                f"an array of shape {shape} and dtype {dtype} whose {n} bytes are not in the message"
            )
        return np.frombuffer(self.blob[off : off + n], dtype=dtype).reshape(shape).copy()

    def node(self, node: Any, depth: int) -> Any:
        if depth > MAX_DEPTH:
            raise WireError(f"nested deeper than {MAX_DEPTH} levels")
        if node is None or isinstance(node, (bool, int, float, str)):
            return node
        if isinstance(node, list):
            return [self.node(v, depth + 1) for v in node]
        if not isinstance(node, dict) or not isinstance(node.get(_TAG), str):
            raise WireError(f"an unknown node {type(node).__name__}")
        kind = node[_TAG]
        if kind == "nd":
            return self.array(node)
        if kind == "float":
            return _non_finite(node.get("v"))
        if kind == "tuple":
            return tuple(self.node(v, depth + 1) for v in _as_list(node.get("v")))
        if kind == "dict":
            return self.mapping(node, depth)
        if kind in ("enum", "obj"):
            return self.typed(node, depth)
        raise WireError(f"an unknown node kind {kind[:20]!r}")

    def mapping(self, node: dict[str, Any], depth: int) -> Any:
        out = {}
        for pair in _as_list(node.get("v")):
            if not (isinstance(pair, list) and len(pair) == 2 and isinstance(pair[0], str)):
                raise WireError("a malformed dict entry")
            out[pair[0]] = self.node(pair[1], depth + 1)
        if len(out) == 1 and _TAG + "refused" in out:
            return _refused(out[_TAG + "refused"])
        return out

    def typed(self, node: dict[str, Any], depth: int) -> Any:
        cls = _types().get(str(node.get("type")))
        if cls is None:
            raise WireError(f"an unknown type {str(node.get('type'))[:40]!r}")
        if node[_TAG] == "enum":
            if not issubclass(cls, enum.Enum):
                raise WireError(f"{cls.__name__} is not an enum")
            try:
                return cls(node.get("v"))
            except ValueError:
                raise WireError(f"{str(node.get('v'))[:20]!r} is not a {cls.__name__}") from None
        raw = node.get("f")
        if not isinstance(raw, dict) or issubclass(cls, enum.Enum):
            raise WireError(f"a malformed {cls.__name__}")
        fields = {str(k): self.node(v, depth + 1) for k, v in raw.items()}
        builder: Callable[..., Any] = cls
        try:
            return builder(**fields)
        except (TypeError, ValueError) as exc:
            raise WireError(
                f"a {cls.__name__} that cannot be built: {' '.join(str(exc).split())[:120]}"
            ) from None


def _non_finite(text: Any) -> float:
    if text not in ("nan", "inf", "-inf"):
        raise WireError(f"a malformed float node {str(text)[:20]!r}")
    return float(text)


def _as_list(v: Any) -> list[Any]:
    if not isinstance(v, list):
        raise WireError("a malformed node: its items are not a list")
    return v


def _refused(v: Any) -> Refused:
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(s, str) for s in v)):
        raise WireError("a malformed refusal")
    return Refused(v[0][:200], v[1][:300])


def decode(data: bytes | bytearray | memoryview, *, max_bytes: int) -> Any:
    """The plain value of a message made by :func:`encode`; raises :class:`WireError` for
    anything else, and for a message longer than ``max_bytes`` (bytes) before reading it."""
    view = memoryview(data).cast("B")
    if len(view) > max_bytes:
        raise WireError(f"the message has {len(view)} bytes, more than the cap of {max_bytes}")
    head = len(MAGIC) + _LENGTH.size
    if len(view) < head or bytes(view[: len(MAGIC)]) != MAGIC:
        raise WireError("not a droneplan plain-data message (wrong magic)")
    (n,) = _LENGTH.unpack_from(view, len(MAGIC))
    if n > len(view) - head:
        raise WireError(f"a truncated message ({len(view) - head} of {n} document bytes)")
    try:
        doc = json.loads(bytes(view[head : head + n]).decode("utf-8"))
    except (ValueError, RecursionError) as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise WireError(f"an unreadable document ({type(exc).__name__})") from None
    try:
        return _Decoder(view[head + n :]).node(doc, 0)
    except RecursionError:
        raise WireError(f"nested deeper than {MAX_DEPTH} levels") from None
