"""Exhaustive damage enumeration on real request lines: no swap of two bytes, no double flip of the
same bit and no dropped pair of bytes yields a line the board would accept as sealed (protocol 2's
CRC-16), while protocol 1's XOR checksum passed many of them (issue 13)."""

import functools
import itertools
import re

import numpy as np
import pytest

from labkit.arm import segments_from_trajectory
from labkit.arm._protocol import REQUEST_CHECKSUM, checksum, seal


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
    return int(body[k + 1:k + 5], 16) == checksum(body[:k].encode("latin-1"))


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
    print({k: {"damaged": v[0], "pass_crc16": v[1], "pass_xor_v1": v[2]} for k, v in enumeration.items()})


def test_crc_matches_the_published_check_value():
    assert checksum(b"123456789") == 0x29B1  # CRC-16/CCITT-FALSE check value
    assert seal("#1 MOVE 4500 9000 3000 ") == "#1 MOVE 4500 9000 3000 *73E0"  # docs/protocol.md section 7
