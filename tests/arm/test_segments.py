"""Trajectories as SEG segments (labkit/arm/link/_segments.py): a segment too wide for one request line is split
in time into pieces of the same polynomial, and the wire units of the default are right for the robot."""

import ctypes
import math

import numpy as np
import pytest

from labkit.arm import MAX_LINE, Arm, WireUnits, segments_from_trajectory
from labkit.arm._protocol import request_length
from labkit.exceptions import OptionError
from labkit.motion import joint_trajectory
from labkit.robot import Robot
from tests.arm.test_line_limit import chain_robot
from tests.arm.test_motion import host_core


def line_length(seg):
    dur, order, coef = seg
    return request_length("SEG", [dur, order, *coef])


def quintic_plan(q0, q1, duration, t):
    """The quintic rest-to-rest law written out here (not labkit's): joint values [rad] at times ``t`` [s], (m, n)."""
    tau = np.clip(np.asarray(t) / duration, 0.0, 1.0)[:, None]
    return q0 + (q1 - q0) * (10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5)


def record_frames(arm):
    """Record every servo frame of the virtual board: board time [s] and the commanded joints [cdeg]; and when
    the first segment of the next trajectory starts [s]."""
    ex = arm.port.board.executor
    frames, start = [], []
    cmd_seg, servo_frame = ex._cmd_seg, ex._servo_frame

    def seg(args):
        out = cmd_seg(args)
        if not start and ex.segments:
            start.append(ex.segments[0].start)
        return out

    def frame():
        servo_frame()
        frames.append((ex.time, list(ex.q)))

    ex._cmd_seg, ex._servo_frame = seg, frame
    return frames, start


@pytest.fixture
def robot_named(tmp_path):
    def load(name):
        if name.startswith("chain"):
            path = tmp_path / f"{name}.toml"
            path.write_text(chain_robot(int(name[5:])))
            return Robot.load(path)
        return Robot.load(name)

    return load


@pytest.mark.parametrize("name, fraction, first, last, duration", [
    ("puma560", 0.15, None, None, 0.6),  # every joint over 70 % of its range in 0.6 s
    ("chain7", None, -120.0, 120.0, 1.0),
    ("chain8", None, 10.0, 80.0, 1.0),
])
def test_a_fast_quintic_too_wide_for_a_line_runs_split_and_follows_the_plan(robot_named, name, fraction, first, last,
                                                                             duration):
    robot = robot_named(name)
    if fraction is None:
        q0, q1 = np.radians(np.linspace(first, first + 5, robot.n)), np.radians(np.linspace(last, last - 5, robot.n))
    else:
        lo, hi = np.array([lk.limits for lk in robot.links]).T
        q0, q1 = lo + fraction * (hi - lo), hi - fraction * (hi - lo)
    traj = joint_trajectory(robot, q0, q1, duration, law="quintic", dt=0.01)
    units = WireUnits(robot)
    segs = segments_from_trajectory(traj, order=5, units=units)
    assert max(line_length(s) for s in segs) <= MAX_LINE
    assert len(segs) > round(duration / 0.05), "some 50 ms segments were split (a line too long for them)"
    assert sum(d for d, _, _ in segs) == round(duration * 1000) and min(d for d, _, _ in segs) >= 1
    for (_, order, a), (_, _, b) in zip(segs, segs[1:]):  # each piece ends exactly where the next starts
        np.testing.assert_array_equal(np.reshape(a, (-1, order + 1)).sum(axis=1), np.reshape(b, (-1, order + 1))[:, 0])

    with Arm(robot, "sim://?clock=lockstep") as arm:
        arm.move_joints(q0, wait=True)
        frames, start = record_frames(arm)
        report = arm.run_trajectory(traj, order=5)
        assert report.segments == len(segs) and report.retries == 0
        np.testing.assert_allclose(arm.commanded_joints(), q1, rtol=0, atol=math.radians(0.01))
    t = np.array([f[0] for f in frames]) - start[0]
    commanded = np.array([f[1] for f in frames])[(t >= 0) & (t <= duration)]
    plan = np.degrees(quintic_plan(q0, q1, duration, t[(t >= 0) & (t <= duration)])) * 100  # revolute: cdeg
    assert len(commanded) >= duration / 0.02 - 1
    # within the wire's quantisation: integer coefficients, a few centidegrees at most
    assert np.abs(commanded - plan).max() <= 3.0


def test_a_segment_too_wide_even_in_pieces_of_a_millisecond_is_refused_and_nothing_is_sent(robot_named):
    robot = robot_named("chain8")  # eight joints moving at -100 deg: six characters each even at rest
    q0, q1 = np.radians(np.full(8, -120.0)), np.radians(np.full(8, 120.0))
    traj = joint_trajectory(robot, q0, q1, 1.0, law="quintic", dt=0.01)
    with Arm(robot, "sim://?clock=lockstep") as arm:
        arm.move_joints(q0, wait=True)
        sent, done = arm.stats.sent, arm.port.board.executor.done
        with pytest.raises(OptionError) as info:
            arm.run_trajectory(traj, order=5)
        assert arm.stats.sent == sent and arm.port.board.executor.done == done
        np.testing.assert_allclose(arm.commanded_joints(), q0, rtol=0, atol=math.radians(0.01))
        arm.run_trajectory(traj, order=3)  # the cubic's four coefficients a joint fit
        np.testing.assert_allclose(arm.commanded_joints(), q1, rtol=0, atol=math.radians(0.01))
    text = str(info.value)
    assert "at most 164 bytes" in text and "8 joints of order 5" in text and "pieces of 1 ms" in text
    assert "nothing was sent" in text and "order=3" in text


def test_segments_that_fit_are_not_split():
    traj = joint_trajectory(None, np.radians([10.0, 20.0, 30.0]), np.radians([100.0, 50.0, 0.0]), 2.0, law="quintic",
                            dt=0.01)
    for order in (3, 5):
        segs = segments_from_trajectory(traj, order=order, min_duration=0.1)
        assert [d for d, _, _ in segs] == [100] * 20


def test_the_default_units_are_centidegrees_for_revolute_joints_and_refused_for_prismatic_ones():
    arm3 = Robot.load("arduino_arm_3dof")
    traj = joint_trajectory(arm3, np.radians([30.0, 40.0, 50.0]), np.radians([120.0, 80.0, 20.0]), 1.0, dt=0.05)
    assert segments_from_trajectory(traj) == segments_from_trajectory(traj, units=WireUnits(arm3))

    l16 = Robot.load("cylindrical_l16")  # a hobby servo turning, two RC linear servos (1/18000 of a stroke)
    goal = np.array([math.radians(-20.0), 0.030, 0.045])
    traj = joint_trajectory(l16, np.array([0.0, 0.05, 0.025]), goal, 2.0, dt=0.1)
    with pytest.raises(OptionError, match=r"expected units=WireUnits\(robot\).*prismatic joint\(s\) \[2, 3\]"):
        segments_from_trajectory(traj)
    segs = segments_from_trajectory(traj, units=WireUnits(l16))
    end = np.reshape(segs[-1][2], (3, 4)).sum(axis=1)
    np.testing.assert_array_equal(end, WireUnits(l16).positions(goal))  # 45 mm of a 50 mm stroke: 16200
    assert end[2] == 16200
    with pytest.raises(OptionError, match="expected units of 3 joints .* got units of 6"):
        segments_from_trajectory(traj, units=WireUnits(Robot.load("puma560")))


@pytest.fixture(scope="module")
def firmware_poly(tmp_path_factory):
    """q [cdeg] of one joint's row ``el_ms`` into a segment of ``dur_ms``, as the firmware's servo frame computes it."""
    core = host_core(tmp_path_factory.mktemp("core"))
    core.lk_poly.restype = ctypes.c_int32
    core.lk_poly.argtypes = [ctypes.POINTER(ctypes.c_int32), ctypes.c_uint8, ctypes.c_int32]

    def run(row, el_ms, dur_ms):
        s24 = (el_ms << 24) // dur_ms  # lk_frame: s = floor(el 2^24 / dur) for el < dur, 2^24 at the end
        return core.lk_poly((ctypes.c_int32 * len(row))(*row), len(row) - 1, s24)

    return run


@pytest.mark.firmware
def test_the_firmware_runs_the_pieces_of_a_split_quintic_on_the_plan(robot_named, firmware_poly):
    """Every millisecond of an 8-joint quintic split into 76 pieces, evaluated by the firmware's integer Horner
    (``lk_poly``, 1/16 cdeg, rounded to a centidegree) as its servo frames do, against the quintic law."""
    robot = robot_named("chain8")
    q0, q1 = np.radians(np.linspace(10.0, 15.0, 8)), np.radians(np.linspace(80.0, 75.0, 8))
    segs = segments_from_trajectory(joint_trajectory(robot, q0, q1, 1.0, law="quintic", dt=0.01), order=5)
    assert len(segs) > 20
    got, start = [], 0
    for dur, order, coef in segs:
        rows = np.reshape(coef, (8, order + 1)).tolist()
        got += [[firmware_poly(row, el, dur) for row in rows] for el in range(dur)]
        start += dur
    got.append([firmware_poly(row, dur, dur) for row in rows])  # the last segment's end, held
    plan = np.degrees(quintic_plan(q0, q1, 1.0, np.arange(start + 1) / 1000.0)) * 100
    assert start == 1000 and np.abs(np.array(got) - plan).max() <= 3.0
    np.testing.assert_array_equal(got[-1], np.round(np.degrees(q1) * 100))
