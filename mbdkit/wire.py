"""The messages between the grader and its sandbox child: JSON, with float arrays as base64 bytes.

Never pickle: the grader reads what an untrusted process wrote, and unpickling runs code. A message is
one JSON object; an array is ``{"__array__": [shape], "data": base64 of little-endian float64}``. The
decoder checks sizes and shapes, so a malformed or hostile message is a ``WireError``, nothing worse.

What the grader reads from a child is checked further, one validating function per kind of message:
``reply`` (a probe's answer) and ``ready`` (the child's first message) against a JSON schema (keys,
types, sizes; strict JSON: no NaN, no huge integers), with every string made printable text (``clean``).
Frames (``multiprocessing.connection``'s: a 4-byte big-endian length, then the bytes) are read and
written by ``receive`` and ``send`` with a deadline on the whole frame: a child that announces 1000
bytes and sends 1, or never reads what the grader sends, costs a timeout of that check, never a hang.
"""

from __future__ import annotations

import base64
import functools
import json
import math
import os
import select
import struct
import time

import fastjsonschema
import numpy as np

MAX_MESSAGE = 64 * 2**20
"""Largest message the grader reads from a child (bytes)."""


class WireError(ValueError):
    """A message that cannot be decoded."""


class FrameTimeout(TimeoutError):
    """A frame not (wholly) read or written by its deadline; ``partial``: some of it was."""

    def __init__(self, partial: bool):
        super().__init__("a partial frame" if partial else "no frame")
        self.partial = partial


def _encode(value):
    if isinstance(value, np.ndarray):
        data = np.asarray(value, dtype="<f8")  # (not ascontiguousarray: it makes a 0-d array 1-d)
        return {"__array__": list(data.shape), "data": base64.b64encode(data.tobytes(order="C")).decode("ascii")}
    if isinstance(value, dict):
        return {str(k): _encode(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_encode(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return {"__float__": repr(value)}
    return value


def _decode(value):
    if isinstance(value, dict):
        if "__array__" in value:
            shape = value["__array__"]
            if not isinstance(shape, list) or not all(isinstance(s, int) and s >= 0 for s in shape):
                raise WireError("bad array shape")
            raw = base64.b64decode(value.get("data", ""), validate=True)
            if len(raw) != 8 * math.prod(shape):
                raise WireError("array size does not match its shape")
            return np.frombuffer(raw, dtype="<f8").reshape(tuple(shape)).astype(float)
        if "__float__" in value:
            return float(value["__float__"])
        return {k: _decode(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v) for v in value]
    return value


def dumps(message: dict) -> bytes:
    """Encode a message (dicts, lists, numbers, strings, float arrays)."""
    return json.dumps(_encode(message), allow_nan=True).encode()


def loads(data: bytes) -> dict:
    """Decode a message; raise WireError on anything malformed."""
    if len(data) > MAX_MESSAGE:
        raise WireError("message too large")
    try:
        message = json.loads(data.decode())
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as err:
        raise WireError(f"not a message: {err}") from None
    if not isinstance(message, dict):
        raise WireError("not a message: expected an object")
    try:
        return _decode(message)
    except (ValueError, TypeError, RecursionError) as err:
        raise WireError(f"bad message: {err}") from None


# -- what the grader accepts from a child ----------------------------------------------------------------------
TEXT = 4096
"""Longest string of a reply (a message, a place, a name): the child's own messages are shorter."""
_STRING = {"type": "string", "maxLength": TEXT}
_ARRAY = {
    "type": "object",
    "additionalProperties": False,
    "required": ["__array__", "data"],
    "properties": {
        "__array__": {"type": "array", "maxItems": 8, "items": {"type": "integer", "minimum": 0, "maximum": 2**40}},
        "data": {"type": "string", "maxLength": MAX_MESSAGE},
    },
}
_ERROR_FIELDS = {
    "type": {"type": "string", "maxLength": 200},
    "message": _STRING,
    "where": _STRING,
    "trace": {"type": "array", "maxItems": 20, "items": _STRING},
    "code": {"type": ["integer", "null"]},
}
REPLY_SCHEMA = {
    "type": "object",
    "additionalProperties": False,
    "required": ["status"],
    "properties": {
        "status": {"enum": ["ok", "error"]},
        "outputs": {
            "type": "object",
            "maxProperties": 64,
            "propertyNames": {"maxLength": 100},
            "additionalProperties": _ARRAY,
        },
        "error": {"type": "object", "additionalProperties": False, "properties": _ERROR_FIELDS},
        "element_errors": {
            "type": "array",
            "maxItems": 10_000,
            "items": {
                "type": "object",
                "additionalProperties": False,
                "required": ["element", "method"],
                "properties": {"element": _STRING, "method": {"type": "string", "maxLength": 200}, **_ERROR_FIELDS},
            },
        },
        "seconds": {"type": "number", "minimum": 0},
        "printed": {"type": "integer", "minimum": 0},
        "output_head": _STRING,
    },
}
"""A probe's reply (``_child._run``)."""
READY_SCHEMA = {
    "type": "object",
    "additionalProperties": False,
    "required": ["status"],
    "properties": {
        "status": {"enum": ["ready", "setup_failed"]},
        "network_isolated": {"type": "boolean"},
        "seccomp": {"type": "boolean"},
        "message": _STRING,
    },
}
"""The child's first message (``_child.serve``)."""


@functools.cache
def _validator(kind: str):
    return fastjsonschema.compile({"reply": REPLY_SCHEMA, "ready": READY_SCHEMA}[kind])


def _strict(constant: str):
    raise ValueError(f"{constant} is not JSON")


def _parse(data: bytes) -> object:
    if len(data) > MAX_MESSAGE:
        raise WireError("message too large")
    try:
        return json.loads(data.decode("utf-8"), parse_constant=_strict)
    except (ValueError, RecursionError) as err:  # also not UTF-8, and integers of thousands of digits
        raise WireError(f"not JSON ({type(err).__name__})") from None


def _validated(kind: str, data: bytes) -> dict:
    """``data`` parsed and checked against the schema of ``kind``, arrays decoded, strings cleaned."""
    message = _parse(data)
    try:
        _validator(kind)(message)
    except fastjsonschema.JsonSchemaValueException as err:
        path = [p for p in err.path[1:2] if p in REPLY_SCHEMA["properties"] or p in READY_SCHEMA["properties"]]
        field = f"{path[0]!r} " if path else ""
        raise WireError(f"{field}fails the rule {err.rule or 'of its schema'!r}") from None
    try:
        return clean(_decode(message))
    except (ValueError, TypeError, OverflowError, MemoryError) as err:
        raise WireError(f"bad array ({type(err).__name__})") from None


def reply(data: bytes) -> dict:
    """A probe's reply, validated (``REPLY_SCHEMA``); WireError with a short reason otherwise."""
    return _validated("reply", data)


def ready(data: bytes) -> dict:
    """A child's first message, validated (``READY_SCHEMA``); WireError otherwise."""
    return _validated("ready", data)


def text(value: str) -> str:
    """A string from a child as text that can be written anywhere: lone surrogates (JSON allows them,
    UTF-8 does not) as ``\\udce9``."""
    try:
        value.encode("utf-8")
        return value
    except UnicodeEncodeError:
        return value.encode("utf-8", "backslashreplace").decode("utf-8")


def clean(value):
    """Every string of a decoded message through ``text`` (keys too)."""
    if isinstance(value, str):
        return text(value)
    if isinstance(value, dict):
        return {text(k): clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [clean(v) for v in value]
    return value


# -- frames with a deadline ---------------------------------------------------------------------------------
def _wait(fd: int, events: int, deadline: float, partial: bool) -> None:
    poller = select.poll()
    poller.register(fd, events | select.POLLERR | select.POLLHUP)
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise FrameTimeout(partial)
        if poller.poll(max(1, int(left * 1000))):
            return


def _read(fd: int, size: int, deadline: float, partial: bool) -> bytes:
    chunks, got = [], 0
    while got < size:
        _wait(fd, select.POLLIN, deadline, partial or got > 0)
        try:
            chunk = os.read(fd, min(size - got, 2**20))
        except BlockingIOError:
            continue
        if not chunk:
            raise EOFError("the child closed its connection")
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)


def receive(fd: int, deadline: float, grace: float = 1.0, limit: int = MAX_MESSAGE) -> bytes:
    """One frame from ``fd``: its first byte by ``deadline`` (``time.monotonic``), all of it by
    ``deadline + grace``; FrameTimeout otherwise, EOFError when the child closed, WireError when it
    announces more than ``limit`` bytes."""
    header = _read(fd, 4, deadline, False)
    (size,) = struct.unpack("!i", header)
    if size < 0 or size > limit:
        raise WireError(f"a frame of more than {limit} bytes")  # not its size: the child chose that number
    return _read(fd, size, deadline + grace, True)


def send(fd: int, data: bytes, deadline: float) -> None:
    """Write one frame to ``fd`` (non-blocking, made so here) by ``deadline``: FrameTimeout when the
    child does not take it (it does not read), OSError when it is gone."""
    os.set_blocking(fd, False)
    view, sent = memoryview(struct.pack("!i", len(data)) + data), 0
    while sent < len(view):
        _wait(fd, select.POLLOUT, deadline, sent > 0)
        try:
            sent += os.write(fd, view[sent:])
        except BlockingIOError:
            continue
