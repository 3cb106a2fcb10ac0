"""Check codes of the six devices' protocols (``shared/specs/protocols.md``, Appendix A)."""

from __future__ import annotations

__all__ = ["crc16_sick", "crc16_xmodem", "nmea_checksum", "odrive_checksum", "xor_checksum"]


def _xmodem_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return tuple(table)


_XMODEM = _xmodem_table()


def crc16_xmodem(data: bytes, crc: int = 0) -> int:
    """CRC-16/XMODEM (poly 0x1021, init 0, no reflection): the AMC drives' CRC.

    >>> hex(crc16_xmodem(b"123456789"))
    '0x31c3'
    """
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ _XMODEM[((crc >> 8) ^ b) & 0xFF]
    return crc


def crc16_sick(data: bytes) -> int:
    """SICK LMS2xx CRC over STX … last payload byte (sent little-endian).

    >>> hex(crc16_sick(bytes.fromhex("0200010031")))
    '0x1215'
    """
    crc, prev = 0, 0
    for b in data:
        crc = (((crc & 0x7FFF) << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1) & 0xFFFF
        crc ^= (prev << 8) | b
        prev = b
    return crc


def nmea_checksum(body: str) -> str:
    """XOR of the characters strictly between ``$`` and ``*``, as two upper-case hex digits.

    >>> nmea_checksum("C320.5P0.2R-18.3T19.0")
    '3C'
    """
    c = 0
    for ch in body:
        c ^= ord(ch)
    return f"{c:02X}"


def odrive_checksum(text: str) -> int:
    """ODrive ASCII protocol: XOR of every character before ``*`` (sent in decimal).

    >>> odrive_checksum("r vbus_voltage ")
    93
    """
    c = 0
    for ch in text:
        c ^= ord(ch)
    return c


def xor_checksum(data: bytes) -> int:
    """XOR of all bytes (RPLidar requests; BNO055 does not use one).

    >>> hex(xor_checksum(bytes.fromhex("A5F0029402")))
    '0xc1'
    """
    c = 0
    for b in data:
        c ^= b
    return c
