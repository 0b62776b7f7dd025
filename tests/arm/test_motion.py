"""The board's motion checks (labkit/arm/_segment_check.py, docs/protocol.md 4.3): never lenient, rarely strict,
and decided exactly like the firmware's lk_check (compiled for the host and called through ctypes)."""

from __future__ import annotations

import ctypes
import shutil
import subprocess

import numpy as np
import pytest

from labkit.arm import FIRMWARE_DIR, VirtualBoard
from labkit.arm._segment_check import check, segment_position_ok, segment_speed_ok
from labkit.arm.link._segments import check_segment_positions, feasible_ranges, move_duration_ms, move_segment
from labkit.exceptions import JointLimitError
from labkit.robot import Robot


def dense_extremes(coef, kind, n=20001):
    """Smallest and largest value of q, dq/ds or d2q/ds2 (kind 0, 1, 2) at n evenly spaced s in [0, 1]."""
    p = np.polynomial.polynomial.polyder(np.asarray(coef, float), kind) if kind else np.asarray(coef, float)
    v = np.polynomial.polynomial.polyval(np.linspace(0.0, 1.0, n), p)
    return v.min(), v.max()


def random_case(rng):
    """A random segment row and check (kind, lo, hi, x, y) with the limit 0.9 .. 1.1 of the extreme."""
    order = int(rng.choice([3, 5]))
    mag = int(rng.choice([100, 3000, 30000, 1_000_000, 10_000_000]))
    coef = [int(v) for v in rng.integers(-mag, mag + 1, order + 1)]
    if rng.random() < 0.25:  # rest-to-rest shapes, like MOVEs and trajectories
        d = int(rng.integers(-9000, 9001))
        coef = [int(rng.integers(0, 18001)), 0] + ([3 * d, -2 * d] if order == 3 else [0, 10 * d, -15 * d, 6 * d])
    kind = int(rng.integers(0, 3))
    lo, hi = dense_extremes(coef, kind)
    f = rng.uniform(0.9, 1.1)
    if kind == 0:
        mid, half = (lo + hi) / 2, (hi - lo) / 2 * f + 1
        return coef, kind, int(np.floor(mid - half)), int(np.ceil(mid + half)), 0, 0
    dur = int(rng.integers(1, 60001))
    y, scale = (dur, 1e3) if kind == 1 else (dur * dur, 1e6)
    x = int(max(abs(lo), abs(hi)) * f * scale / y)
    if not 1 <= x <= (1_000_000 if kind == 1 else 100_000_000):  # what LIMITS accepts
        return None
    return coef, kind, 0, 0, x, y


def test_never_lenient_and_strict_only_at_the_limit():
    rng = np.random.default_rng(7)
    lenient, strict, accepted, n = [], [], 0, 0
    while n < 3000:
        case = random_case(rng)
        if case is None:
            continue
        coef, kind, lo, hi, x, y = case
        ok = check(coef, kind, lo, hi, x, y)
        e_lo, e_hi = dense_extremes(coef, kind)
        if kind == 0:
            margin = min(e_lo - lo, hi - e_hi) / (hi - lo)
        else:
            limit = x * y / (1e3 if kind == 1 else 1e6)
            margin = (limit - max(abs(e_lo), abs(e_hi))) / limit
        if ok and margin < -1e-12:
            lenient.append(case)
        if not ok and margin > 1e-3:
            strict.append(case)
        accepted += ok
        n += 1
    assert not lenient, lenient[:3]
    assert not strict, strict[:3]
    assert n // 4 < accepted < 3 * n // 4


def test_peaks_between_the_old_samples_are_refused():
    # speed: samples s = k/16 reach 5400, the peak at s = 17/32 5418.75 cdeg (90 ms at 600 deg/s allow 5400)
    assert not segment_speed_ok([9000, 0, 10200, -6400], 90, 60000, 0)
    assert segment_speed_ok([9000, 0, 10200, -6400], 91, 60000, 0)
    # position: samples s = k/32 reach 17994, the peak 18002 cdeg
    assert not segment_position_ok([9000, 34917, -33859, 0], 0, 18000)
    assert segment_position_ok([9000, 34917, -33859, 0], 0, 18010)


def test_exact_at_the_ends_and_at_the_middle():
    # a rest-to-rest cubic: |dq/ds| peaks at s = 1/2 (1.5 dq), |d2q/ds2| at the ends (6 dq)
    c = [0, 0, 3000, -2000]
    assert check(c, 1, x=1500, y=1000) and not check(c, 1, x=1499, y=1000)
    assert check(c, 2, x=6000, y=1_000_000) and not check(c, 2, x=5999, y=1_000_000)
    assert segment_position_ok(c, 0, 1000) and not segment_position_ok(c, 0, 999) and not segment_position_ok(c, 1, 1000)
    # the shortest MOVE the limits allow is the one the analytic peaks give (45 deg at 300 deg/s: 225 ms)
    assert move_duration_ms([4500], [9000], [30000], [0]) == 225
    _, _, coef = move_segment([4500], [9000], 225)
    assert segment_speed_ok(coef, 225, 30000, 0) and not segment_speed_ok(coef, 224, 30000, 0)


def test_a_quintic_acceleration_peak_inside_the_segment():
    c = [8000, 2500, 1563, 4375, -7188, 2750]  # |d2q/ds2| peaks at 5378 inside the segment
    peak = max(abs(v) for v in dense_extremes(c, 2))
    assert 5377 < peak < 5379
    assert not segment_speed_ok(c, 180, 30000, 150000)  # 4860 allowed
    assert segment_speed_ok(c, 250, 30000, 150000)  # 9375 allowed
    assert segment_speed_ok(c, 180, 30000, 0)  # acceleration unchecked


def test_the_host_refuses_a_segment_leaving_the_range_between_samples_like_the_board():
    robot = Robot.load("arduino_arm_3dof")
    board = VirtualBoard(robot)
    ranges = feasible_ranges(robot)
    assert ranges == [board.executor._feasible(j) for j in range(robot.n)]  # the board booted with the robot file's calibration
    lo, hi = ranges[0]
    mid = [[(a + b) // 2, 0, 0, 0] for a, b in ranges[1:]]
    touches = [hi - 100, 400, -400, 0]  # ends at hi - 100, peaks at hi (s = 1/2)
    overshoots = [hi - 100, 420, -420, 0]  # peaks 5 cdeg beyond hi
    check_segment_positions(robot, [(500, 3, [c for row in [touches, *mid] for c in row])])
    with pytest.raises(JointLimitError, match=r"segment 1 \(500 ms\): joint 1 \(.*\) leaves its range") as info:
        check_segment_positions(robot, [(500, 3, [c for row in [touches, *mid] for c in row]),
                                        (500, 3, [c for row in [overshoots, *mid] for c in row])])
    assert info.value.joint == 0


def host_core(directory):
    """The firmware's core (``labkit_core.c``), built for the host as a shared library in ``directory`` (ctypes)."""
    cc = shutil.which("cc") or shutil.which("gcc")
    lib = directory / "labkit_core.so"
    subprocess.run([cc, "-shared", "-fPIC", "-O1", "-std=c99", f"-I{FIRMWARE_DIR / 'labkit_arm'}",
                    str(FIRMWARE_DIR / "labkit_arm" / "labkit_core.c"), str(FIRMWARE_DIR / "tests" / "hw_stub.c"),
                    "-o", str(lib)], check=True, capture_output=True)
    return ctypes.CDLL(str(lib))


@pytest.fixture(scope="module")
def firmware_check(tmp_path_factory):
    """The firmware's lk_check, built for the host as a shared library."""
    core = host_core(tmp_path_factory.mktemp("core"))
    core.lk_check.restype = ctypes.c_uint8
    core.lk_check.argtypes = [ctypes.POINTER(ctypes.c_int32), ctypes.c_uint8, ctypes.c_uint8, ctypes.c_int32,
                              ctypes.c_int32, ctypes.c_uint32, ctypes.c_uint32, ctypes.POINTER(ctypes.c_int32)]
    scratch = (ctypes.c_int32 * 64)()

    def run(coef, kind, lo, hi, x, y):
        return bool(core.lk_check((ctypes.c_int32 * len(coef))(*coef), len(coef) - 1, kind, lo, hi, x, y, scratch))

    return run


@pytest.mark.firmware
def test_the_firmware_decides_exactly_like_the_host(firmware_check):
    rng = np.random.default_rng(11)
    cases = [c for c in (random_case(rng) for _ in range(4000)) if c is not None]
    # and segments on the edge: limits at the exact extreme and one unit either side
    for coef in ([0, 0, 3000, -2000], [9000, 0, 10200, -6400], [8000, 2500, 1563, 4375, -7188, 2750]):
        for x in range(5370, 5430, 3):
            cases += [(coef, 1, 0, 0, x, 1000), (coef, 2, 0, 0, x, 1_000_000), (coef, 0, 9000 - x, 9000 + x, 0, 0)]
    differ = [c for c in cases if firmware_check(*c) != check(*c)]
    assert len(cases) > 3000 and not differ, differ[:5]
