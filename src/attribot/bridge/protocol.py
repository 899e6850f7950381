"""Wire format of the bridge: length-prefixed messages over TCP, one request at a time.

A message is a 12-byte prefix `b"ATB1"`, the header length and the payload length (big-endian uint32),
then the header (UTF-8 JSON object) and the payload (raw bytes: JPEG frame, depth, segmentation). The
client sends a request and waits for its reply before the next one; see docs/bridge-protocol.md.
"""

from __future__ import annotations

import json
import socket
import struct
from typing import Any

__all__ = [
    "PROTOCOL_VERSION",
    "MAGIC",
    "MAX_HEADER",
    "MAX_PAYLOAD",
    "ProtocolError",
    "send_message",
    "recv_message",
]

PROTOCOL_VERSION = 1
MAGIC = b"ATB1"
MAX_HEADER = 1 << 20  # 1 MiB of JSON
MAX_PAYLOAD = 64 << 20  # a 4K frame with depth and segmentation fits
_PREFIX = struct.Struct(">4sII")


class ProtocolError(Exception):
    """The peer sent something that is not a bridge message, or closed the connection."""


def send_message(sock: socket.socket, header: dict[str, Any], payload: bytes = b"") -> None:
    """Send one message: prefix, JSON header, payload."""
    head = json.dumps(header, separators=(",", ":")).encode("utf-8")
    sock.sendall(_PREFIX.pack(MAGIC, len(head), len(payload)) + head + payload)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    chunks = []
    left = n
    while left:
        chunk = sock.recv(min(left, 1 << 20))
        if not chunk:
            raise ProtocolError("the connection closed in the middle of a message" if left < n else "closed")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def recv_message(sock: socket.socket) -> tuple[dict[str, Any], bytes]:
    """Receive one message; `ProtocolError` on a closed connection or a malformed message."""
    magic, head_len, payload_len = _PREFIX.unpack(_recv_exact(sock, _PREFIX.size))
    if magic != MAGIC:
        raise ProtocolError(f"not an attribot bridge message (bad magic {magic!r})")
    if head_len > MAX_HEADER or payload_len > MAX_PAYLOAD:
        raise ProtocolError(f"message too large: header {head_len}, payload {payload_len} bytes")
    try:
        header = json.loads(_recv_exact(sock, head_len).decode("utf-8"))
    except ValueError as exc:
        raise ProtocolError(f"message header is not JSON: {exc}") from None
    if not isinstance(header, dict):
        raise ProtocolError("message header is not a JSON object")
    return header, _recv_exact(sock, payload_len) if payload_len else b""
