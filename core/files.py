"""Reading JSON documents that users hand to droneplan (instance, library and GeoJSON files), safely.

:func:`read_json` reads a ``.json`` file, or a gzip-compressed ``.json.gz`` one, and parses it.
Whatever the file holds, it returns the document or raises :class:`JsonFileError`, a
``ValueError`` whose one-line message starts with the path: a missing or unreadable file, a
truncated or corrupt gzip stream, a file that expands beyond ``max_bytes`` (checked while it is
decompressed, so a small file that would expand to gigabytes costs ``max_bytes`` and no more), text
that is not UTF-8, invalid JSON (line and column) and a document nested too deeply to parse.
"""

from __future__ import annotations

import json
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["MAX_JSON_BYTES", "JsonFileError", "read_json"]

MAX_JSON_BYTES = 512 << 20
"""The largest (decompressed) JSON document :func:`read_json` reads by default (bytes)."""

_CHUNK = 1 << 20


class JsonFileError(ValueError):
    """A JSON file that cannot be read (the message is one line and starts with the path)."""


def _gunzip(path: Path, data: bytes, max_bytes: int) -> bytes:
    inflate = zlib.decompressobj(wbits=31)  # 31: the gzip container
    out = bytearray()
    try:
        view = memoryview(data)
        while view:
            out += inflate.decompress(view[:_CHUNK], max(1, max_bytes + 1 - len(out)))
            if len(out) > max_bytes:
                raise JsonFileError(f"{path}: expands beyond {max_bytes} bytes; not read")
            view = view[_CHUNK:] if not inflate.unconsumed_tail else memoryview(inflate.unconsumed_tail)
        out += inflate.flush()
    except zlib.error as exc:
        raise JsonFileError(f"{path}: not a readable gzip file ({exc})") from None
    if not inflate.eof:
        raise JsonFileError(f"{path}: a truncated gzip file")
    if len(out) > max_bytes:
        raise JsonFileError(f"{path}: expands beyond {max_bytes} bytes; not read")
    return bytes(out)


def read_json(
    path: str | Path,
    *,
    max_bytes: int = MAX_JSON_BYTES,
    parse_constant: Callable[[str], Any] | None = None,
) -> Any:
    """The JSON document in ``path`` (gzip-compressed when the name ends in ``.gz``).

    max_bytes: the largest document read (bytes, after decompression). parse_constant: as for
    :func:`json.loads` (called for ``NaN``, ``Infinity``, ``-Infinity``; may raise ValueError).
    Raises :class:`JsonFileError` (module docstring); FileNotFoundError for a missing file.
    """
    file = Path(path)
    try:
        data = file.read_bytes()
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise JsonFileError(f"{file}: cannot be read ({exc.strerror or exc})") from None
    if file.name.endswith(".gz"):
        data = _gunzip(file, data, max_bytes)
    elif len(data) > max_bytes:
        raise JsonFileError(f"{file}: larger than {max_bytes} bytes; not read")
    try:
        return json.loads(data.decode("utf-8"), parse_constant=parse_constant)
    except UnicodeDecodeError as exc:
        raise JsonFileError(f"{file}: not UTF-8 text (byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise JsonFileError(
            f"{file}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise JsonFileError(f"{file}: JSON nested too deeply to read") from None
    except ValueError as exc:  # parse_constant's refusal
        raise JsonFileError(f"{file}: {' '.join(str(exc).split())[:200]}") from None
