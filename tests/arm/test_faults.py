"""Fault injection: every command completes or raises DeviceError; no corrupt data accepted; every loss reported."""

import numpy as np
import pytest
import serial

from labkit.exceptions import DeviceError
from labkit.arm import FaultConfig, FaultyPort
from labkit.arm import Arm, segments_from_trajectory
from labkit.arm.urlhandler import register

register()
NOISY = dict(corrupt=0.01, drop=0.005)  # the acceptance level: 1 % corrupted bytes, 0.5 % lost bytes


def faulty(seed, **kw):
    raw = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.05)
    return raw, FaultyPort(raw, FaultConfig(seed=seed, **kw))


class _Traj:
    """A minimal sampled trajectory (t, q, qd, qdd)."""

    def __init__(self, t, q, qd):
        self.t, self.q, self.qd, self.qdd = t, q, qd, None


def wave(q0, n_segments, dt=0.05):
    t = np.arange(n_segments + 1) * dt
    shape = np.array([1.0, 0.5, -0.5])
    w = 2 * np.pi / 10.0
    q = q0 + 0.3 * np.sin(w * t)[:, None] * shape
    qd = 0.3 * w * np.cos(w * t)[:, None] * shape
    return _Traj(t, q, qd)


def check_stream(raw, df):
    """Every accepted frame equals what the board sent; received + lost = sent in the window."""
    truth = raw.board.sent_frames
    for c, t, *adc in zip(df["counter"], df["t"], df["adc0"], df["adc1"], df["adc2"], df["pot"]):
        assert truth[c] == (round(t * 1000), tuple(adc))
    sent = sum(1 for t_ms, _ in truth.values() if t_ms < round(df.attrs["t_stop"] * 1000))
    assert len(df) + df.attrs["lost"] == sent == df.attrs["expected"]


@pytest.mark.parametrize("seed", [0, 1])
def test_60s_feedback_stream_under_corruption_and_loss(seed):
    raw, port = faulty(seed, **NOISY)
    with Arm("arduino_arm_3dof", port, timeout=0.005, retries=40) as arm:
        df = arm.stream(60.0, hz=50)
    check_stream(raw, df)
    assert df.attrs["lost"] > 500  # ~40 % of the 35-byte frames are hit at this error rate...
    assert len(df) > 1500  # ... and the rest arrive intact
    assert port.counts.corrupted["read"] > 500 and port.counts.dropped["read"] > 200


@pytest.mark.slow
def test_1000_segment_trajectory_under_corruption_and_loss():
    raw, port = faulty(2, **NOISY)
    with Arm("arduino_arm_3dof", port, timeout=0.005, retries=40) as arm:
        arm.set_host_timeout(0)
        board = raw.board.executor
        accepted = []
        orig = board._cmd_seg

        def spy(args):
            out = orig(args)
            accepted.append(list(args))
            return out

        board._cmd_seg = spy
        segs = segments_from_trajectory(wave(arm.commanded_joints(), 1000))
        report = arm.run_trajectory(segs)
    # every segment ran exactly once, exactly as sent, in order
    assert accepted == [[d, o, *c] for d, o, c in segs]
    assert report.segments == 1000 and board.done == 1000
    assert report.retries > 1000  # the faults were real ...
    assert arm.stats.verified > 50  # ... and lost acknowledgements were settled by STATUS
    assert port.counts.corrupted["write"] > 500 and port.counts.dropped["write"] > 200


def test_short_trajectory_under_faults_in_both_directions():
    raw, port = faulty(3, **NOISY)
    with Arm("arduino_arm_3dof", port, timeout=0.005, retries=40) as arm:
        board = raw.board.executor
        accepted = []
        orig = board._cmd_seg

        def spy(args):
            out = orig(args)  # raises if rejected
            accepted.append(list(args))
            return out

        board._cmd_seg = spy
        segs = segments_from_trajectory(wave(arm.commanded_joints(), 60))
        report = arm.run_trajectory(segs)
        moves = []
        orig_move = board._cmd_move

        def spy_move(args):
            out = orig_move(args)
            moves.append(list(args))
            return out

        board._cmd_move = spy_move
        for k in range(10):
            arm.move_joints(np.radians([20.0 + k, 30.0, 40.0]))
    # a MOVE runs as one cubic segment (docs/protocol.md 4.2): the spy also sees those 10
    assert accepted[:60] == [[d, o, *c] for d, o, c in segs] and len(accepted) == 60 + 10
    assert report.segments == 60 and board.done == 60 + 10
    assert [m[:3] for m in moves] == [[2000 + 100 * k, 3000, 4000] for k in range(10)]  # each move ran once


def test_delays_are_survived():
    raw, port = faulty(5, delay=0.2, delay_s=0.03)
    with Arm("arduino_arm_3dof", port, timeout=0.05, retries=10) as arm:
        for k in range(20):
            arm.move_joints(np.radians([10.0 + k, 20.0, 30.0]))
        np.testing.assert_allclose(np.degrees(arm.commanded_joints()), [29.0, 20.0, 30.0], atol=1e-6)
        df = arm.stream(2.0, hz=50)
    check_stream(raw, df)
    assert port.counts.delayed > 5


def test_disconnect_mid_trajectory_raises_device_error():
    raw, port = faulty(6, disconnect_after=3000)
    with Arm("arduino_arm_3dof", port, timeout=0.01) as arm:
        segs = segments_from_trajectory(wave(arm.commanded_joints(), 200))
        with pytest.raises(DeviceError, match="vanished"):
            arm.run_trajectory(segs)
        assert 0 < raw.board.executor.done + len(raw.board.executor.segments) < 200
        with pytest.raises(DeviceError):
            arm.ping()
    assert port.counts.disconnected


def test_fault_config_validation():
    with pytest.raises(ValueError, match="corrupt as a probability"):
        FaultConfig(corrupt=1.5)
    with pytest.raises(ValueError, match="direction one of"):
        FaultConfig(direction="sideways")
    assert FaultConfig(direction="read").direction.value == "read"
