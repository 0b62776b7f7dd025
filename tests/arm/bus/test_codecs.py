"""The bus packet codecs of labkit.arm.bus, against the protocols' published check values and by hand."""

import pytest

from labkit.arm.bus import _dynamixel as dxl
from labkit.arm.bus import _feetech as sts


def test_dynamixel_crc_is_crc16_buypass():
    # polynomial 0x8005, init 0, not reflected: the catalogue check value of "123456789" is 0xFEE8
    assert dxl.crc16(b"123456789") == 0xFEE8


def test_dynamixel_ping_packet_matches_the_emanual():
    # ROBOTIS e-Manual, Protocol 2.0, "Ping" example: ID 1 -> FF FF FD 00 01 03 00 01 19 4E
    assert dxl.encode(1, 0x01, []).hex(" ") == "ff ff fd 00 01 03 00 01 19 4e"


def test_dynamixel_byte_stuffing_round_trip():
    params = [0x74, 0x00, 0xFF, 0xFF, 0xFD, 0x00]
    packet = dxl.encode(1, 0x03, params)
    assert b"\xff\xff\xfd\xfd" in packet[7:]  # stuffed on the wire
    assert dxl.decode(packet) == ([(1, 0x03, params)], b"", [])


def test_dynamixel_decoder_rejects_damage_and_waits_for_more():
    good = dxl.encode(7, 0x02, [0x84, 0x00, 0x04, 0x00])
    bad = bytearray(good)
    bad[-1] ^= 0xFF
    packets, rest, rejected = dxl.decode(bytes(bad) + good[:5])
    assert packets == [] and rest == good[:5] and rejected == ["CRC mismatch"]
    unstuffed = bytearray(dxl.HEADER + bytes([1, 7, 0, 0x03, 0xFF, 0xFF, 0xFD, 0x01]))
    crc = dxl.crc16(unstuffed)
    packets, _, rejected = dxl.decode(bytes(unstuffed) + bytes([crc & 0xFF, crc >> 8]))
    assert packets == [] and rejected == ["unstuffed FF FF FD in the parameters"]


def test_feetech_checksum_and_round_trip():
    # Feetech's manual: read position of ID 1 -> FF FF 01 04 02 38 02 BE
    assert sts.encode(1, 0x02, [0x38, 0x02]).hex(" ") == "ff ff 01 04 02 38 02 be"
    packet = sts.status(3, 0x20, [1, 2, 3])
    assert sts.decode(packet) == ([(3, 0x20, [1, 2, 3])], b"", [])
    damaged = packet[:-1] + bytes([packet[-1] ^ 1])
    assert sts.decode(damaged)[2] == ["checksum mismatch"]


@pytest.mark.parametrize("value, expected", [(0x8005, -5), (0x0005, 5), (0, 0)])
def test_feetech_sign_magnitude(value, expected):
    assert sts.signed(value) == expected
