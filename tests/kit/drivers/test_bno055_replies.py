"""The BNO055's two kinds of failure kept apart: the chip refusing a request (``EE`` with a
status of its own) is a ``DeviceError`` with the chip's code, raised at once; a reply garbled
on the line (``EE`` with a status the chip does not have, the wrong kind or length of reply)
is asked again and, if it never comes right, a ``ProtocolError`` — never "the device
refused"."""

from __future__ import annotations

import pytest
import serial

from kit.drivers import DeviceError, ProtocolError, bno055


class _Answers:
    """A port whose chip answers the n-th request with ``replies[n]`` (the last repeated)."""

    def __init__(self, *replies: bytes) -> None:
        self.port = serial.serial_for_url("loop://", timeout=0.001)
        self.replies = list(replies)
        self.requests = 0

    def __getattr__(self, name):
        return getattr(self.port, name)

    def write(self, data):
        self.port.write(self.replies[min(self.requests, len(self.replies) - 1)])
        self.requests += 1
        return len(data)


@pytest.mark.parametrize(("reply", "why"), [
    (b"\xee\x94", r"a garbled reply \(EE 94\)"),  # the line of garbage
    (b"\xee\x01", r"a garbled reply \(EE 01\)"),  # a write's "success" to a read
    (b"\xbb\x02\x00\x00", r"a garbled reply \(2 data bytes instead of 6\)"),
])
def test_a_garbled_reply_is_asked_again_and_is_a_protocol_error(reply, why):
    port = _Answers(reply)
    imu = bno055.BNO055(port, timeout=0.02, retries=2)
    with pytest.raises(ProtocolError, match=rf"BNO055: read Euler angles: {why} after 3 "
                                            r"tries: line noise") as info:
        imu.euler()
    assert not isinstance(info.value, DeviceError) and port.requests == 3


def test_a_garbled_reply_then_a_good_one_gives_the_reading():
    imu = bno055.BNO055(_Answers(b"\xee\x94", bytes.fromhex("BB06A00560FF5800")),
                        timeout=0.02)
    assert imu.euler() == (90.0, -10.0, 5.5)  # protocols.md §5.6's Euler vector
    assert imu.retried == 1


def test_the_chips_refusal_is_a_device_error_with_its_code_at_once():
    port = _Answers(b"\xee\x05")
    imu = bno055.BNO055(port, timeout=0.02, retries=5)
    with pytest.raises(DeviceError, match=r"BNO055: write 0x00: the chip refused: register "
                                          r"write disabled \(0x05\)") as info:
        imu.write_register(0x00, 0x12)
    assert info.value.code == 5 and port.requests == 1  # not asked again
