"""Wire format of the bridge: length-prefixed messages over TCP, one request at a time.

A message is a 12-byte prefix `b"ATB1"`, the header length and the payload length (big-endian uint32),
then the header (UTF-8 JSON object) and the payload (raw bytes: JPEG frame, depth, segmentation). The
client sends a request and waits for its reply before the next one; see docs/bridge-protocol.md.

Whatever arrives is bounded before it is decoded: the lengths against the reader's limits before anything
is read, the header's nesting depth before `json.loads` (whose recursion a message 200,000 deep would
exhaust), and a number too long for a float becomes an infinity, which every request refuses.
"""

from __future__ import annotations

import json
import re
import socket
import struct
import time
from typing import Any

__all__ = [
    "PROTOCOL_VERSION",
    "MAGIC",
    "MAX_HEADER",
    "MAX_PAYLOAD",
    "MAX_DEPTH",
    "ProtocolError",
    "ConnectionClosed",
    "MessageError",
    "send_message",
    "recv_message",
    "decode_header",
]

PROTOCOL_VERSION = 1
MAGIC = b"ATB1"
MAX_HEADER = 1 << 20  # 1 MiB of JSON
MAX_PAYLOAD = 64 << 20  # a 4K frame with depth and segmentation fits
MAX_DEPTH = 16
"""The deepest nesting of arrays and objects a header may have (the deepest real one, a hello, has 4)."""
_PREFIX = struct.Struct(">4sII")
_STRUCTURE = re.compile(rb'[\[\]{}"\\]')  # what changes the nesting: brackets, and the strings around them
_LONGEST_INT = 18  # digits: longer integers are read as floats (an infinity past 308 digits)


class ProtocolError(Exception):
    """The peer sent something that is not a bridge message, or closed the connection: the connection
    cannot go on."""


class ConnectionClosed(ProtocolError):
    """The peer closed the connection (between messages, or in the middle of one)."""


class MessageError(ProtocolError):
    """A message arrived whole, but its header is not a JSON object within the limits (too deep, not JSON,
    not UTF-8): the connection can go on with the next message."""


def send_message(sock: socket.socket, header: dict[str, Any], payload: bytes = b"") -> None:
    """Send one message: prefix, JSON header, payload."""
    head = json.dumps(header, separators=(",", ":")).encode("utf-8")
    sock.sendall(_PREFIX.pack(MAGIC, len(head), len(payload)) + head + payload)


def _recv_exact(sock: socket.socket, n: int, deadline: float | None = None) -> bytes:
    chunks = []
    left = n
    while left:
        if deadline is not None:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise ProtocolError("the rest of a message did not arrive in time")
            sock.settimeout(remaining)
        try:
            chunk = sock.recv(min(left, 1 << 20))
        except socket.timeout:  # noqa: UP041 (Python 3.8: not yet TimeoutError)
            if deadline is None:
                raise
            raise ProtocolError("the rest of a message did not arrive in time") from None
        if not chunk:
            if left < n:
                raise ConnectionClosed("the connection closed in the middle of a message")
            raise ConnectionClosed("closed")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def nesting(raw: bytes, limit: int = MAX_DEPTH) -> int:
    """How deep the arrays and objects of the JSON text `raw` nest, counted up to `limit + 1` (a scan of
    its brackets and quotes only, so it costs little and never recurses)."""
    if raw.count(b"[") + raw.count(b"{") <= limit:
        return limit  # cannot nest deeper (the common case: no scan)
    depth = deepest = 0
    in_string = False
    escaped = -1  # the index of a byte a backslash escapes
    for match in _STRUCTURE.finditer(raw):
        at = match.start()
        if at == escaped:
            continue
        char = raw[at]
        if in_string:
            if char == 0x5C:  # backslash
                escaped = at + 1
            elif char == 0x22:  # quote
                in_string = False
        elif char == 0x22:
            in_string = True
        elif char in (0x5B, 0x7B):  # [ {
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > limit:
                    break
        elif char in (0x5D, 0x7D):  # ] }
            depth -= 1
    return deepest


def _number(digits: str) -> Any:
    # an integer of thousands of digits is not a robot's number: as a float it is an infinity, which the
    # requests refuse as a value (and int() of it is slow on Python 3.8, and refused past 4300 digits later)
    return int(digits) if len(digits) <= _LONGEST_INT else float(digits)


def decode_header(raw: bytes) -> dict[str, Any]:
    """The JSON object of a message header; `MessageError` when it is not one within the limits."""
    deepest = nesting(raw)
    if deepest > MAX_DEPTH:
        raise MessageError(f"message header nests arrays or objects more than {MAX_DEPTH} deep")
    try:
        header = json.loads(raw.decode("utf-8"), parse_int=_number)
    except (ValueError, RecursionError) as exc:  # UnicodeDecodeError is a ValueError
        raise MessageError(f"message header is not UTF-8 JSON: {str(exc)[:120]}") from None
    if not isinstance(header, dict):
        raise MessageError("message header is not a JSON object")
    return header


def recv_message(
    sock: socket.socket,
    max_header: int = MAX_HEADER,
    max_payload: int = MAX_PAYLOAD,
    within_s: float | None = None,
) -> tuple[dict[str, Any], bytes]:
    """Receive one message; `ProtocolError` on a closed connection or a message over the limits (the
    connection cannot go on), `MessageError` on a whole message whose header cannot be read (it can).

    `within_s`: once the message's first byte has arrived, the rest must arrive within this many seconds (a
    peer that trickles a message must not hold the reader); the socket's own time-out is restored after."""
    before = sock.gettimeout()
    deadline = None
    try:
        if within_s is None:
            prefix = _recv_exact(sock, _PREFIX.size)
        else:
            first = _recv_exact(sock, 1)  # waiting for a message to begin is not trickling it
            deadline = time.monotonic() + within_s
            prefix = first + _recv_exact(sock, _PREFIX.size - 1, deadline)
        magic, head_len, payload_len = _PREFIX.unpack(prefix)
        if magic != MAGIC:
            raise ProtocolError(f"not an attribot bridge message (bad magic {magic!r})")
        if head_len > max_header or payload_len > max_payload:
            raise ProtocolError(
                f"message too large: header {head_len} bytes (at most {max_header}), payload {payload_len} "
                f"bytes (at most {max_payload})"
            )
        raw = _recv_exact(sock, head_len, deadline)
        payload = _recv_exact(sock, payload_len, deadline) if payload_len else b""
    finally:
        if deadline is not None:
            sock.settimeout(before)
    return decode_header(raw), payload
