"""What the grader reads from a sandbox child: replies checked against their schema, frames read and written
with a deadline, stack-dump lines of an exact form only (``mbdkit.wire``, ``mbdkit.sandbox``)."""

from __future__ import annotations

import json
import os
import socket
import struct
import time

import numpy as np
import pytest

from mbdkit import sandbox, wire

GOOD = {
    "status": "ok",
    "outputs": {"psi": np.arange(6.0).reshape(3, 2)},
    "element_errors": [
        {"element": "j1", "method": "constraints", "type": "ValueError", "message": "m", "where": "", "trace": []}
    ],
    "seconds": 0.25,
    "printed": 12,
    "output_head": "hello",
}


def test_a_well_formed_reply_is_read():
    message = wire.reply(wire.dumps(GOOD))
    np.testing.assert_array_equal(message["outputs"]["psi"], GOOD["outputs"]["psi"])
    assert message["element_errors"] == GOOD["element_errors"] and message["printed"] == 12


@pytest.mark.parametrize(
    "change",
    [
        {"printed": "lots"},
        {"printed": True},
        {"printed": -1},
        {"status": "passed"},
        {"element_errors": [{"element": ["j1"], "method": "constraints"}]},
        {"element_errors": [{"element": "j1", "method": "constraints", "extra": 1}]},
        {"error": {"type": "E", "code": "27"}},
        {"outputs": {"psi": [1.0, 2.0]}},
        {"outputs": {"psi": {"__array__": [2, 2], "data": "AAAA"}}},
        {"outputs": {"psi": {"__array__": [2**50], "data": ""}}},
        {"output_head": "x" * (wire.TEXT + 1)},
        {"surprise": 1},
    ],
)
def test_a_malformed_reply_is_a_wire_error(change):
    message = {k: v for k, v in wire._encode(GOOD).items()}
    message.update(change)
    with pytest.raises(wire.WireError):
        wire.reply(json.dumps(message).encode())


@pytest.mark.parametrize(
    "data",
    [b'{"status": "ok", "seconds": NaN}', b'{"status": "ok", "printed": 1' + b"0" * 5000 + b"}", b"\xff", b"[" * 10**5],
)
def test_text_that_is_not_strict_json_is_a_wire_error(data):
    with pytest.raises(wire.WireError):
        wire.reply(data)


def test_strings_of_a_reply_become_writable_text():
    message = wire.reply(b'{"status": "error", "error": {"type": "E", "message": "caf\\udce9 \\ud800"}}')
    text = message["error"]["message"]
    assert text.encode("utf-8") and "caf" in text


def test_a_partial_frame_is_a_timeout_not_a_hang():
    ours, theirs = socket.socketpair()
    with ours, theirs:
        theirs.sendall(struct.pack("!i", 1000) + b"{")
        start = time.monotonic()
        with pytest.raises(wire.FrameTimeout) as late:
            wire.receive(ours.fileno(), start + 0.1, grace=0.1)
        assert late.value.partial and time.monotonic() - start < 5
        with pytest.raises(wire.FrameTimeout) as nothing:
            wire.receive(theirs.fileno(), time.monotonic() + 0.05)
        assert not nothing.value.partial


def test_frames_round_trip_and_a_closed_peer_is_eof():
    ours, theirs = socket.socketpair()
    with ours:
        deadline = time.monotonic() + 5
        data = os.urandom(300_000)  # more than a socket buffer: written in parts while the other side reads
        theirs.setblocking(True)
        from threading import Thread

        reader = Thread(target=lambda: received.append(wire.receive(theirs.fileno(), deadline)))
        received: list[bytes] = []
        reader.start()
        wire.send(ours.fileno(), data, deadline)
        reader.join()
        assert received == [data]
        theirs.close()
        with pytest.raises(EOFError):
            wire.receive(ours.fileno(), time.monotonic() + 5)


def test_a_child_that_does_not_read_cannot_block_the_grader():
    ours, theirs = socket.socketpair()
    with ours, theirs:
        with pytest.raises(wire.FrameTimeout):
            wire.send(ours.fileno(), b"x" * 2**24, time.monotonic() + 0.1)


def test_a_frame_larger_than_allowed_is_refused():
    ours, theirs = socket.socketpair()
    with ours, theirs:
        theirs.sendall(struct.pack("!i", -1) + struct.pack("!Q", 2**40))
        with pytest.raises(wire.WireError):
            wire.receive(ours.fileno(), time.monotonic() + 5)


@pytest.mark.parametrize(
    "line",
    [
        "STUCK\t/submission/modules/a.py\t\u00b2\tf",  # str.isdigit() is true for "²", int() is not
        "STUCK\t/submission/modules/a.py\t\u0663\tf",  # an Arabic-Indic 3: int() takes it, the grader does not
        "STUCK\trelative.py\t3\tf",
        "STUCK\t/submission/modules/a.py\t1234567890\tf",
        "STUCK\t/submission/modules/a.py\t3\t" + "f" * 2000,
    ],
)
def test_a_stack_dump_line_of_another_form_is_ignored(line):
    assert sandbox._stuck_line(line + "\n") is None
    assert sandbox._stuck_line(line + "\nSTUCK\t/submission/modules/a.py\t3\tf\n") == (
        "/submission/modules/a.py",
        3,
        "f",
    )


def test_exit_and_faulthandler_lines_are_read_only_in_their_exact_form():
    assert sandbox._exit_line("EXIT\t/s/m.py\t12\tf\t-3\n") == ("/s/m.py", 12, "f", -3)
    assert sandbox._exit_line("EXIT\t\t0\t\t3\n") == ("", 0, "", 3)
    assert sandbox._exit_line("EXIT\t/s/m.py\t\u00b2\tf\t3\nEXIT\t/s/m.py\t1\tf\t\u00b9\n") is None
    dump = 'Stack (most recent call first):\n  File "/s/m.py", line \u00b2 in f\n  File "/s/m.py", line 7 in g\n'
    assert sandbox.stack_samples(dump) == [[("/s/m.py", 7, "g")]]
