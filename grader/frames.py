"""Messages between the grader and a submission's process: length-prefixed frames.

A frame is a JSON header and zero or more binary blobs (array data travels as raw bytes)::

    u32 header length | u32 number of blobs | header (UTF-8 JSON) | (u64 length | bytes)*

:func:`send` and :func:`recv` block (the submission's side). The grader reads with
:class:`Reader`, which never blocks past a deadline and never believes a length: a frame over
:data:`MAX_FRAME` bytes, a header that is not a JSON object, or a stream that ends inside a
frame is a :class:`FrameError` — what a submission writes cannot make the grader wait,
allocate or parse more than it allows.

Standard library only: the sandbox imports it before anything else.
"""

from __future__ import annotations

import json
import select
import socket
import struct
import time
from collections.abc import Sequence
from typing import Any

__all__ = ["MAX_FRAME", "FrameError", "FrameTimeout", "Reader", "encode", "recv", "send"]

MAX_FRAME = 256 * 1024 * 1024
MAX_BLOBS = 4096
_HEAD = struct.Struct(">II")
_BLOB = struct.Struct(">Q")


class FrameError(ValueError):
    """A malformed frame, or the other end closed the stream."""


class FrameTimeout(TimeoutError):
    """No whole frame arrived before the deadline."""


def encode(header: dict[str, Any], blobs: Sequence[bytes | memoryview] = ()) -> list[bytes]:
    text = json.dumps(header, separators=(",", ":")).encode("utf-8")
    parts = [_HEAD.pack(len(text), len(blobs)), text]
    for blob in blobs:
        parts += [_BLOB.pack(len(blob)), bytes(blob)]
    return parts


def send(sock: socket.socket, header: dict[str, Any],
         blobs: Sequence[bytes | memoryview] = ()) -> None:
    """Write one frame (blocking)."""
    sock.sendall(b"".join(encode(header, blobs)))


def _read_exactly(sock: socket.socket, n: int) -> bytes:
    chunks, left = [], n
    while left:
        chunk = sock.recv(min(left, 1 << 20))
        if not chunk:
            raise FrameError("the stream ended inside a frame")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def recv(sock: socket.socket) -> tuple[dict[str, Any], list[bytes]]:
    """Read one frame (blocking); the side that trusts its peer (the submission's)."""
    first = sock.recv(_HEAD.size, socket.MSG_WAITALL)
    if not first:
        raise FrameError("the stream ended")
    if len(first) < _HEAD.size:
        first += _read_exactly(sock, _HEAD.size - len(first))
    size, count = _HEAD.unpack(first)
    header = json.loads(_read_exactly(sock, size))
    blobs = [_read_exactly(sock, _BLOB.unpack(_read_exactly(sock, _BLOB.size))[0])
             for _ in range(count)]
    return header, blobs


class Reader:
    """The grader's side of a stream from a submission: bounded in time and size."""

    def __init__(self, sock: socket.socket, limit: int = MAX_FRAME) -> None:
        self.sock = sock
        self.limit = limit
        self.buffer = bytearray()
        sock.setblocking(False)

    def _fill(self, n: int, deadline: float) -> None:
        while len(self.buffer) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise FrameTimeout("no answer in time")
            ready, _, _ = select.select([self.sock], [], [], left)
            if not ready:
                continue
            try:
                chunk = self.sock.recv(max(n - len(self.buffer), 1 << 16))
            except BlockingIOError:
                continue
            except OSError as exc:
                raise FrameError(f"the stream failed: {exc.strerror}") from None
            if not chunk:
                raise FrameError("the stream ended")
            self.buffer += chunk

    def _take(self, n: int) -> bytes:
        out = bytes(self.buffer[:n])
        del self.buffer[:n]
        return out

    def read(self, deadline: float) -> tuple[dict[str, Any], list[bytes]]:
        """The next frame, by ``deadline`` (``time.monotonic()``)."""
        self._fill(_HEAD.size, deadline)
        size, count = _HEAD.unpack(self.buffer[:_HEAD.size])
        if size > self.limit or count > MAX_BLOBS:
            raise FrameError("a frame larger than the grader reads")
        self._fill(_HEAD.size + size, deadline)
        del self.buffer[:_HEAD.size]
        try:
            header = json.loads(self._take(size))
        except (ValueError, UnicodeDecodeError):
            raise FrameError("a frame whose header is not JSON") from None
        if not isinstance(header, dict):
            raise FrameError("a frame whose header is not a JSON object")
        blobs, total = [], size
        for _ in range(count):
            self._fill(_BLOB.size, deadline)
            (length,) = _BLOB.unpack(self._take(_BLOB.size))
            total += length
            if total > self.limit:
                raise FrameError("a frame larger than the grader reads")
            self._fill(length, deadline)
            blobs.append(self._take(length))
        return header, blobs


def write_all(sock: socket.socket, parts: Sequence[bytes], deadline: float) -> None:
    """Send ``parts`` on a non-blocking socket by ``deadline`` (a submission that stops
    reading cannot make the grader wait); raises :class:`FrameTimeout` or
    :class:`FrameError`."""
    data = memoryview(b"".join(parts))
    while data:
        left = deadline - time.monotonic()
        if left <= 0:
            raise FrameTimeout("the submission did not read its question in time")
        _, ready, _ = select.select([], [sock], [], left)
        if not ready:
            continue
        try:
            data = data[sock.send(data):]
        except BlockingIOError:
            continue
        except OSError as exc:
            raise FrameError(f"the stream failed: {exc.strerror}") from None
