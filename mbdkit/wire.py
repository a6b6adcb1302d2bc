"""The messages between the grader and its sandbox child: JSON, with float arrays as base64 bytes.

Never pickle: the grader reads what an untrusted process wrote, and unpickling runs code. A message is
one JSON object; an array is ``{"__array__": [shape], "data": base64 of little-endian float64}``. The
decoder checks sizes and shapes, so a malformed or hostile message is a ``WireError``, nothing worse.
"""

from __future__ import annotations

import base64
import json
import math

import numpy as np

MAX_MESSAGE = 64 * 2**20
"""Largest message the grader reads from a child (bytes)."""


class WireError(ValueError):
    """A message that cannot be decoded."""


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
