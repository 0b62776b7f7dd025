"""The line checksum (CRC-32 since protocol 3, issue 27).

Exhaustive damage enumeration on real request lines: no swap of two bytes, no double flip of the same bit
and no dropped pair of bytes yields a line the board would accept as sealed, while protocol 1's XOR checksum
passed many of them (issue 13). And the wrong reply a fault run accepted under protocol 2 (a damaged
``STATUS`` reply whose CRC-16 still matched, issue 27): rebuilt here by a small search, it passes a CRC-16 but
not the CRC-32, and the host drops it and asks again.
"""

import binascii
import functools
import itertools
import re
import zlib

import numpy as np
import pytest
import serial

from labkit.arm import Arm, PortWrapper, segments_from_trajectory
from labkit.arm._protocol import REQUEST_CHECKSUM, checksum, seal, unseal
from labkit.arm.link._replies import parse_status
from labkit.arm.urlhandler import register

register()


class _Traj:
    def __init__(self, t, q, qd):
        self.t, self.q, self.qd, self.qdd = t, q, qd, None


def request_lines():
    """Lines exactly as the host writes them: MOVEs, SEGs of a real trajectory, GRIP, CAL, STOP."""
    t = np.arange(6) * 0.1
    q = np.radians(45 + 20 * np.sin(t))[:, None] * np.array([1.0, 1.5, 0.8])
    qd = np.radians(20 * np.cos(t))[:, None] * np.array([1.0, 1.5, 0.8])
    bodies = [f"MOVE {4500 + 37 * k} {9000 - 11 * k} {3000 + 5 * k}" for k in range(3)]
    bodies += [" ".join(["SEG", str(d), str(o), *map(str, c)]) for d, o, c in segments_from_trajectory(_Traj(t, q, qd))]
    bodies += ["GRIP 1500", "CAL 2 600 2400 18000 -1 0 17000", "STOP", "TIMEOUT 500"]
    return [seal(f"#{1000 + k} {b} ").encode() for k, b in enumerate(bodies)]


def board_accepts_sealed(line: bytes) -> bool:
    """Would a board take ``line`` as a sealed request (the checks of docs/protocol.md 2.1)?"""
    text = line.decode("latin-1").strip(" \t")
    body = text[1:] if text.startswith("$") else text
    k = body.rfind("*")
    if k < 0 or not REQUEST_CHECKSUM.match(body[k + 1:]):
        return False
    return int(body[k + 1:k + 9], 16) == checksum(body[:k].encode("latin-1"))


def xor_accepts(line: bytes) -> bool:
    """Protocol 1's rule for the same line with a two-digit XOR checksum (for comparison)."""
    body, star, hh = line.rpartition(b"*")
    if not star or re.fullmatch(rb"[0-9A-Fa-f]{2}", hh) is None:
        return False
    return functools.reduce(lambda a, b: a ^ b, body, 0) == int(hh, 16)


def damaged(line: bytes):
    """Every swap of two different bytes, double flip of one bit, and dropped pair of bytes."""
    n = len(line)
    for i, j in itertools.combinations(range(n), 2):
        if line[i] != line[j]:
            b = bytearray(line)
            b[i], b[j] = b[j], b[i]
            yield "swap", bytes(b)
        for bit in range(8):
            b = bytearray(line)
            b[i] ^= 1 << bit
            b[j] ^= 1 << bit
            yield "flip", bytes(b)
        yield "drop", line[:i] + line[i + 1:j] + line[j + 1:]


@pytest.fixture(scope="module")
def enumeration():
    counts = {"swap": [0, 0, 0], "flip": [0, 0, 0], "drop": [0, 0, 0]}  # total, CRC passes, XOR passes
    for line in request_lines():
        assert board_accepts_sealed(line)
        v1 = line[:line.rindex(b"*")]
        v1 += b"*%02X" % functools.reduce(lambda a, b: a ^ b, v1, 0)
        for kind, bad in damaged(line):
            if bad == line:
                continue
            c = counts[kind]
            c[0] += 1
            # a pass is a *different* request accepted (a hex digit of the CRC changing case, "0fe6" for
            # "0FE6", is the same request and runs correctly)
            c[1] += board_accepts_sealed(bad) and bad.rpartition(b"*")[0] != line.rpartition(b"*")[0]
        for kind, bad in damaged(v1):
            if bad != v1 and bad.rpartition(b"*")[0] != v1.rpartition(b"*")[0]:
                counts[kind][2] += xor_accepts(bad)
    return counts


def test_no_damaged_request_passes_the_crc(enumeration):
    for kind, (total, crc_passes, _) in enumeration.items():
        assert total > 10_000, (kind, total)
        assert crc_passes == 0, f"{crc_passes} of {total} {kind}s pass the CRC"


def test_the_enumeration_would_catch_a_weak_checksum(enumeration):
    """The same enumeration finds many damaged lines that protocol 1's XOR checksum passed."""
    assert enumeration["swap"][2] > 1000 and enumeration["flip"][2] > 1000
    print({k: {"damaged": v[0], "pass_crc32": v[1], "pass_xor_v1": v[2]} for k, v in enumeration.items()})


def test_crc_matches_the_published_check_value():
    assert checksum(b"123456789") == 0xCBF43926  # CRC-32/ISO-HDLC check value
    assert checksum("123456789") == zlib.crc32(b"123456789") and checksum(b"") == 0
    assert seal("#1 MOVE 4500 9000 3000 1000 ") == "#1 MOVE 4500 9000 3000 1000 *09D36844"  # docs/protocol.md 2.1


def crc16_collision(body):
    """A wrong ``STATUS`` reply body with the CRC-16 of ``body``: joint 0 ten degrees off, then a search over
    the last two digits of the other joints and of ``mem=`` and ``t=`` (10^8 candidates, about 1500 matches)."""
    target = binascii.crc_hqx(body, 0xFFFF)
    m = re.search(rb"q=(-?\d+),", body)
    wrong = bytearray(body[:m.start(1)] + str(int(m.group(1)) + 1000).encode() + body[m.end(1):])
    free = []
    for field in (rb"q=-?\d+,(-?\d+)", rb"q=-?\d+,-?\d+,(-?\d+)", rb" mem=(\d+)", rb" t=(\d+)"):
        f = re.search(field, bytes(wrong))
        if f and f.end(1) - f.start(1) >= 3:
            free += [f.end(1) - 2, f.end(1) - 1]
    assert len(free) >= 6, body
    for digits in itertools.product(b"0123456789", repeat=len(free)):
        for k, d in zip(free, digits):
            wrong[k] = d
        if binascii.crc_hqx(bytes(wrong), 0xFFFF) == target:
            return bytes(wrong)
    raise AssertionError(f"no CRC-16 collision for {body!r}")


class DamageOneReply(PortWrapper):
    """Between host and board: once armed, puts a wrong body under the true checksum of the next STATUS reply."""

    def __init__(self, port):
        super().__init__(port)
        self.armed = False
        self.swaps = []  # (true body, wrong body)
        self._held = bytearray()

    def read(self, size=1):
        data = self._port.read(size)
        if not self.armed and not self._held:
            return data
        self._held += data
        out = bytearray()
        while (k := self._held.find(b"\r\n")) >= 0:
            line = bytes(self._held[:k])
            del self._held[:k + 2]
            body = unseal(line)
            if self.armed and body is not None and re.match(rb"OK #\d+ STATUS ", body):
                wrong = crc16_collision(body)
                self.swaps.append((body, wrong))
                line = wrong + line[len(body):]  # the wrong body, the true line's CRC-32
                self.armed = False
            out += line + b"\r\n"
        return bytes(out)


def test_a_wrong_reply_that_passes_the_crc16_is_refused_and_asked_again():
    port = DamageOneReply(serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", baudrate=115200, timeout=0.05))
    arm = Arm("arduino_arm_3dof", port, timeout=0.05, retries=3)
    try:
        truth = arm.status()
        sent, bad = arm.stats.sent, arm.stats.bad_lines
        port.armed = True
        status = arm.status()
    finally:
        arm.close()
    (body, wrong), = port.swaps
    # under protocol 2 this line was accepted: the same CRC-16, a valid STATUS, joint 0 off by 10 degrees
    assert wrong != body and binascii.crc_hqx(wrong, 0xFFFF) == binascii.crc_hqx(body, 0xFFFF)
    fake = parse_status(wrong.decode().split()[3:], 3, 6)
    assert abs(np.degrees(fake.q[0] - truth.q[0]) - 10.0) < 1e-6
    # the CRC-32 refuses it: dropped as damaged, the request sent again, the true state returned
    assert zlib.crc32(wrong) != zlib.crc32(body)
    assert unseal(wrong + b"*" + f"{zlib.crc32(body):08X}".encode()) is None
    assert arm.stats.bad_lines == bad + 1 and arm.stats.sent == sent + 2
    np.testing.assert_array_equal(status.q, truth.q)
