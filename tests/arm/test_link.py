"""Tests of the host link (labkit.arm) against the virtual arm."""

import binascii
import math
import re

import numpy as np
import pytest
import serial

from labkit.exceptions import DeviceError, JointLimitError, OptionError, ProtocolError, TrajectoryError
from labkit.arm import FaultConfig, FaultyPort, PortWrapper
from labkit.arm import Arm, CommandRejected, find_ports, segments_from_trajectory
from labkit.arm import checksum
from labkit.arm.urlhandler import register

register()
SIM = "sim://arduino_arm_3dof?clock=lockstep&seed=0"


class Recorder(PortWrapper):
    """A port wrapper recording the lines the host wrote."""

    def __init__(self, port):
        super().__init__(port)
        self.lines = []

    def write(self, data):
        self.lines += [ln for ln in bytes(data).split(b"\n") if ln]
        return self._port.write(data)


@pytest.fixture
def arm():
    with Arm("arduino_arm_3dof", SIM, timeout=0.02) as a:
        yield a


def test_handshake_reads_board_info(arm):
    assert arm.info.protocol == 3 and arm.info.joints == 3 and arm.info.queue == 6
    assert arm.status().state == "IDLE"
    assert arm.ping() >= 0.1  # READY came 0.1 s after power-up
    assert arm.events[0][0] == "READY" and arm.events[0][1][:2] == ["labkit-arm", "3"]


def test_requests_carry_sequence_and_checksum():
    rec = Recorder(serial.serial_for_url(SIM, timeout=0.05))
    with Arm("arduino_arm_3dof", rec, timeout=0.02) as arm:
        arm.ping()
    seqs = []
    for line in rec.lines:
        text = line.decode()
        body, _, hhhh = text.rpartition("*")
        assert len(hhhh) == 8 and int(hhhh, 16) == checksum(body)
        assert text.startswith("#")
        seqs.append(int(text.split()[0][1:]))
    assert seqs == sorted(set(seqs))


def test_calibration_sync_matches_robot_file(arm):
    board = arm.port.board.executor
    assert board.cal[0] == [500, 2500, 0, 1, 0, 18000]
    assert board.cal[3][:2] == [1000, 1900]  # gripper open/closed from the robot file


def test_move_joints_reaches_target_and_reads_back(arm):
    q = np.radians([30.0, 60.0, 45.0])
    arm.move_joints(q, wait=True)
    np.testing.assert_allclose(arm.commanded_joints(), q, atol=1e-4)
    np.testing.assert_allclose(arm.read_joints(), q, atol=math.radians(1.0))


def test_limits_checked_on_host_before_sending():
    rec = Recorder(serial.serial_for_url(SIM, timeout=0.05))
    with Arm("arduino_arm_3dof", rec, timeout=0.02) as arm:
        n = len(rec.lines)
        with pytest.raises(JointLimitError, match="joint 2"):
            arm.move_joints(np.radians([10.0, 190.0, 10.0]))
        with pytest.raises(JointLimitError, match="joint 1"):
            arm.move_joints(np.radians([-5.0, 10.0, 10.0]))
        with pytest.raises(ValueError, match=r"expected q with shape \(\.\.\., 3\)"):
            arm.move_joints([0.1, 0.2])
        with pytest.raises(ValueError, match="finite"):
            arm.move_joints([0.1, np.nan, 0.2])
        assert len(rec.lines) == n  # nothing was sent


def test_servo_range_checked_on_host():
    from labkit.robot import Robot

    robot = Robot.load("arduino_arm_3dof")
    cal = robot.links[1].servo
    narrow = robot.with_link(1, servo=type(cal)(cal.channel, zero=math.radians(30), direction=1,
                                                 angle_range=(0.0, math.pi)))
    with Arm(narrow, SIM, timeout=0.02) as arm:
        with pytest.raises(JointLimitError, match="servo"):
            arm.move_joints(np.radians([10.0, 170.0, 10.0]))


def test_board_rejection_raises_clear_error():
    with Arm("arduino_arm_3dof", SIM, timeout=0.02, sync_calibration=False) as arm:
        arm._transact("CAL", 1, 500, 2500, 0, 1, 0, 9000)  # the board is narrower than the robot file
        with pytest.raises(CommandRejected, match="LIMIT") as info:
            arm.move_joints(np.radians([10.0, 120.0, 10.0]))
        assert info.value.code == 6
        assert isinstance(info.value, DeviceError)


def test_move_to_cartesian_target_through_ik(arm):
    q_true = np.radians([40.0, 60.0, 30.0])
    target = arm.robot.fk(q_true)[:3, 3]
    q = arm.move_to(target, wait=True)
    np.testing.assert_allclose(arm.robot.fk(q)[:3, 3], target, atol=1e-6)
    np.testing.assert_allclose(q, q_true, atol=1e-6)


def test_gripper_and_stop(arm):
    arm.close_gripper()
    assert arm.status().grip_us == 1900
    arm.open_gripper()
    assert arm.status().grip_us == 1000
    with pytest.raises(CommandRejected, match="RANGE"):
        arm.grip(2400)
    held = arm.stop()
    np.testing.assert_allclose(held, arm.commanded_joints())


def test_run_trajectory_streams_segments_and_tracks(arm):
    from labkit.motion import joint_trajectory

    arm.move_joints(np.radians([30.0, 40.0, 50.0]), wait=True)
    traj = joint_trajectory(None, np.radians([30.0, 40.0, 50.0]), np.radians([120.0, 80.0, 20.0]), 3.0, dt=0.05)
    seen = []
    report = arm.run_trajectory(traj, progress=lambda k, n: seen.append((k, n)), min_duration=0.05)
    assert report.segments == len(seen) == seen[-1][1] == 60
    assert report.underruns == 0 and report.retries == 0
    assert report.duration == pytest.approx(3.0, abs=0.15)
    np.testing.assert_allclose(arm.commanded_joints(), np.radians([120.0, 80.0, 20.0]), atol=1e-4)
    assert arm.port.board.executor.done == 1 + 60  # the MOVE ran as one segment, then the trajectory


def test_segments_are_continuous_and_exact_at_the_ends():
    from labkit.motion import joint_trajectory

    traj = joint_trajectory(None, np.radians([10.0, 20.0, 30.0]), np.radians([100.0, 50.0, 0.0]), 2.0, law="quintic",
                            dt=0.01)
    for order in (3, 5):
        segs = segments_from_trajectory(traj, order=order, min_duration=0.1)
        assert sum(d for d, _, _ in segs) == 2000
        ends = []
        for dur, o, coef in segs:
            c = np.array(coef).reshape(3, o + 1)
            if ends:
                np.testing.assert_array_equal(c[:, 0], ends[-1])
            ends.append(c.sum(axis=1))
        np.testing.assert_array_equal(ends[-1], [10000, 5000, 0])
        # the polynomial follows the trajectory to within rounding
        dur, o, coef = segs[len(segs) // 2]
        c = np.array(coef).reshape(3, o + 1)
        k = len(segs) // 2
        mid = np.polynomial.polynomial.polyval(0.5, c.T) / 100
        q_mid = np.degrees(traj.q[np.argmin(np.abs(traj.t - (k * 0.1 + 0.05)))])
        np.testing.assert_allclose(mid, q_mid, atol=0.05)


def test_trajectory_limits_checked_before_sending(arm):
    from labkit.motion import joint_trajectory

    traj = joint_trajectory(None, np.radians([10.0, 20.0, 30.0]), np.radians([100.0, 50.0, 0.0]), 1.0)
    bad = type(traj)(t=traj.t, q=traj.q - math.radians(20.0), qd=traj.qd, qdd=traj.qdd)
    with pytest.raises(JointLimitError):
        arm.run_trajectory(bad)
    assert arm.port.board.executor.done == 0 and arm.status().queue == 0


def test_stream_to_dataframe(arm):
    df = arm.stream(2.0, hz=50)
    assert list(df.columns[:3]) == ["t", "received", "counter"]
    assert df.attrs["lost"] == 0 and df.attrs["expected"] == len(df)
    assert len(df) == pytest.approx(100, abs=2)
    np.testing.assert_allclose(np.diff(df["t"]), 0.02, atol=1e-9)
    assert df["received"].dt.tz is not None
    np.testing.assert_allclose(df["q_base_yaw"].median(), math.pi / 2, atol=0.01)
    assert arm.status().stream_hz == 0
    with pytest.raises(ValueError, match="hz in 1..200"):
        arm.stream(1.0, hz=500)


def test_lost_motion_reply_is_verified_not_repeated():
    """A MOVE whose reply is lost is settled with STATUS, never sent again blindly."""
    raw = serial.serial_for_url(SIM, timeout=0.05)
    with Arm("arduino_arm_3dof", raw, timeout=0.02) as arm:
        board = raw.board.executor
        moves = []
        orig = board._cmd_move

        def counting(args):
            moves.append(list(args))
            return orig(args)

        board._cmd_move = counting
        orig_emit = board._emit
        board._emit = lambda text: None if text.startswith("OK #") and " MOVE" in text else orig_emit(text)
        arm.move_joints(np.radians([20.0, 30.0, 40.0]))
        board._emit = orig_emit
        assert len(moves) == 1 and moves[0][:3] == [2000, 3000, 4000]  # then the duration [ms]
        assert arm.stats.verified == 1


@pytest.mark.parametrize("name, value", [("timeout", float("nan")), ("timeout", float("inf")), ("timeout", 0.0),
                                         ("timeout", -1.0), ("timeout", "0.1"), ("retries", -1), ("retries", 2.5),
                                         ("retries", float("inf"))])
def test_the_timeout_and_retries_setters_refuse_what_the_constructor_refuses(arm, name, value):
    before = getattr(arm, name)
    with pytest.raises(OptionError, match=rf"expected {name} "):
        setattr(arm, name, value)
    with pytest.raises(OptionError, match=rf"expected {name} "):
        Arm("arduino_arm_3dof", SIM, **{name: value})
    assert getattr(arm, name) == before
    setattr(arm, name, 0.5 if name == "timeout" else 3)
    assert getattr(arm, name) == (0.5 if name == "timeout" else 3) and arm.ping() >= 0


def test_timeouts_raise_device_error():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    arm = Arm("arduino_arm_3dof", raw, timeout=0.02, retries=2)
    raw.board.executor._emit = lambda text: None  # the board goes silent
    with pytest.raises(DeviceError, match="PING failed after 3 attempts: no valid reply"):
        arm.ping()
    with pytest.raises(DeviceError, match="STATUS failed"):
        arm.move_joints(np.radians([20.0, 30.0, 40.0]))
    arm.close()


def test_vanished_port_raises_device_error():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    arm = Arm("arduino_arm_3dof", raw, timeout=0.02)
    raw.close()
    with pytest.raises(DeviceError, match="vanished"):
        arm.ping()


def test_garbled_replies_are_never_accepted():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    port = FaultyPort(raw, FaultConfig(seed=4, corrupt=0.01, direction="read"))
    with Arm("arduino_arm_3dof", port, timeout=0.01, retries=60) as arm:
        for _ in range(30):
            st = arm.status()
            assert st.state == "IDLE"
            np.testing.assert_array_equal(np.round(np.degrees(st.q) * 100), [9000, 9000, 9000])
            adc = arm.read_adc()
            assert np.all(np.abs(adc[:3] - 512) < 15) and adc[3] == 512
    assert arm.stats.bad_lines > 10


def test_open_errors():
    with pytest.raises(DeviceError, match="cannot open"):
        Arm("arduino_arm_3dof", "/dev/does-not-exist-labkit")
    with pytest.raises(DeviceError, match="joints"):
        Arm("puma560", "sim://arduino_arm_3dof?clock=lockstep&seed=0")  # a 6-joint robot file, a 3-joint board
    assert isinstance(find_ports(), list)


def test_wrong_protocol_version_is_refused():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    board = raw.board.executor
    orig = board._cmd_hello
    board._cmd_hello = lambda args: orig(args).replace("proto=3", "proto=4")
    with pytest.raises(DeviceError, match=r"firmware 3\.0\.0\) speaks protocol 4, labkit expects protocol 3"):
        Arm("arduino_arm_3dof", raw, timeout=0.02)
    raw2 = serial.serial_for_url(SIM, timeout=0.05)
    raw2.board.executor._cmd_hello = lambda args: "other-board v9"
    with pytest.raises(ProtocolError, match="not a labkit arm"):
        Arm("arduino_arm_3dof", raw2, timeout=0.02)


def v1_board():
    """A virtual board that talks like the protocol-1 firmware (EV BOOT, XOR checksums)."""
    raw = serial.serial_for_url(SIM, timeout=0.05)
    board = raw.board.executor

    def emit(text):
        if text.startswith("READY"):
            text = "EV BOOT labkit-arm fw=1.0.0 proto=1 reset=POWER eeprom=DEFAULTS"
        x = 0
        for ch in text.encode():
            x ^= ch
        board._out += f"{text}*{x:02X}\r\n".encode()

    board._emit = emit
    return raw


def v2_board(ready=True):
    """A virtual board that talks like firmware 2.3.0 (protocol 2: CRC-16 seals ``*HHHH``, 4-digit echoes)."""
    raw = serial.serial_for_url(SIM, timeout=0.05)
    board = raw.board.executor
    handle = board._handle

    def emit(text):
        text = re.sub(r" p=([0-9A-F]{4})[0-9A-F]{4}\b", r" p=\1", text)
        text = text.replace("labkit-arm 3 ", "labkit-arm 2 ").replace("fw=3.0.0 proto=3", "fw=2.3.0 proto=2")
        board._out += f"{text}*{binascii.crc_hqx(text.encode(), 0xFFFF):04X}\r\n".encode()

    def handle_v2(raw_line):  # protocol 3's eight-digit seal is malformed for a protocol-2 board
        if re.search(rb"\*[0-9A-Fa-f]{8}[ \t]*$", raw_line):
            emit("ERR 1 BADCHK malformed")
            return
        handle(raw_line)

    board._emit = emit
    board._handle = handle_v2
    if not ready:  # a board whose auto-reset is disabled: its READY went out before the host opened the port
        board.advance(0.5)
        board.take_output()
    return raw


def test_an_older_board_is_refused_with_what_to_do():
    with pytest.raises(DeviceError, match=r"labkit firmware 1\.0\.0, protocol 1 .*labkit speaks protocol 3 "
                                          r"\(firmware 3\.0\.0 or newer.*flash firmware/labkit_arm"):
        Arm("arduino_arm_3dof", v1_board(), timeout=0.02)


@pytest.mark.parametrize("ready", [True, False])
def test_a_protocol_2_board_is_refused_naming_both_versions(ready):
    # firmware 2.x seals its lines with a CRC-16 (issue 27: too weak); with or without its READY line
    which = r"labkit firmware 2\.3\.0, protocol 2" if ready else "an older labkit firmware, protocol 2"
    with pytest.raises(DeviceError, match=rf"the board runs {which} \(.*\*[0-9A-F]{{4}}'\); labkit speaks protocol 3 "
                                          r"\(firmware 3\.0\.0 or newer: a CRC-32 on every line\): flash firmware"):
        Arm("arduino_arm_3dof", v2_board(ready), timeout=0.02, boot_wait=0.2)


@pytest.mark.parametrize("old", ["2.3.0", "2.99.0"])
def test_a_board_older_than_the_oldest_firmware_driven_is_refused(old):
    raw = serial.serial_for_url(SIM, timeout=0.05)
    orig = raw.board.executor._cmd_hello
    raw.board.executor._cmd_hello = lambda args: orig(args).replace("fw=3.0.0", f"fw={old}")
    with pytest.raises(DeviceError, match=rf"firmware {old}; labkit needs 3\.0\.0 or newer .*flash firmware/labkit_arm"):
        Arm("arduino_arm_3dof", raw, timeout=0.02)


def test_a_newer_board_is_driven():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    newer = raw.board.executor._cmd_hello
    raw.board.executor._cmd_hello = lambda args: newer(args).replace("fw=3.0.0", "fw=3.10.0")
    with Arm("arduino_arm_3dof", raw, timeout=0.02) as arm:  # versions compare as numbers, not text
        assert arm.info.firmware == "3.10.0"


def test_no_ready_and_no_answer_says_what_to_check():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    raw.board.executor._emit = lambda text: None  # a silent device (wrong sketch, wrong baud rate)
    with pytest.raises(DeviceError, match=r"no READY from the board within 0.5 s .*firmware flashed"):
        Arm("arduino_arm_3dof", raw, timeout=0.02, boot_wait=0.5)


def test_a_board_without_auto_reset_is_still_found():
    raw = serial.serial_for_url(SIM, timeout=0.05)
    raw.board.advance(0.5)
    raw.board.take_output()  # its READY went out before the host opened the port
    with Arm("arduino_arm_3dof", raw, timeout=0.02, boot_wait=0.2) as arm:
        assert arm.info.protocol == 3


def test_a_wrong_echo_stops_the_arm_and_names_the_command(arm):
    board = arm.port.board.executor
    orig = board._cmd_move

    def misread(args):  # the board's parser reads something else than what was sent
        args[2] += 100
        return orig(args)

    board._cmd_move = misread
    with pytest.raises(DeviceError, match=r"MOVE 2000 3000 4000 .*echo.*the arm is stopped"):
        arm.move_joints(np.radians([20.0, 30.0, 40.0]))
    assert arm.stats.wrong_echoes == 1


def test_an_unrequested_state_change_is_reported_and_stops_the_arm(arm):
    board = arm.port.board.executor
    board.receive(b"#999 MOVE 1000 2000 3000 1000 *" + f"{checksum('#999 MOVE 1000 2000 3000 1000 '):08X}".encode() + b"\n")
    board.take_output()
    with pytest.raises(DeviceError, match=r"request #999.*unrequested motion.*stopped"):
        arm.status()
    assert board.state == "IDLE"


def test_a_stale_request_is_refused_not_executed_and_not_resent(arm):
    # another program numbered its requests ahead of labkit's: the board refuses labkit's next one as stale (issue 27)
    board = arm.port.board.executor
    body = "#20000 GRIP 1500 "
    board.receive(f"{body}*{checksum(body):08X}\n".encode())
    board.take_output()
    sent, timeout_ms = arm.stats.sent, board.timeout_ms
    with pytest.raises(CommandRejected, match=r"TIMEOUT #\d+ was not executed.*12 STALE after #20000.*another program"
                       ) as info:
        arm._transact("TIMEOUT", timeout_ms + 100)
    assert info.value.code == 12 and info.value.name == "STALE"
    assert arm.stats.sent == sent + 1 and board.timeout_ms == timeout_ms  # sent once, never run


def test_no_port_found(monkeypatch):
    import labkit.arm.link._ports as ports

    monkeypatch.setattr(ports, "list_ports", lambda: [])
    with pytest.raises(DeviceError, match="sim://"):
        Arm("arduino_arm_3dof", None)


def test_stream_reanchors_after_a_genuine_jump(arm):
    board = arm.port.board
    orig = board.executor._stream_frame

    def jump():
        if board.executor.stream_counter == 20:
            board.set_analog(0, 4.0)  # joint 0's pot jumps (a hand pushed the arm)
        orig()

    board.executor._stream_frame = jump
    df = arm.stream(1.0, hz=50)
    assert df.attrs["lost"] <= 1
    assert (df["adc0"] == 819).sum() >= 28  # floor(4.0 * 1024 / 5)


def test_frame_damaged_before_sealing_is_rejected_by_plausibility(arm):
    """A frame whose field is wrong but whose CRC matches (a board bug): the plausibility checks catch it."""
    board = arm.port.board
    orig = board.executor._emit

    def damaged(text):
        if text.startswith("FB 10 "):
            fields = text.split()
            fields[3] = fields[3][:-1]  # joint 0 loses its last digit ("512" -> "51") before the CRC
            text = " ".join(fields)
        orig(text)

    board.executor._emit = damaged
    df = arm.stream(0.5, hz=50)
    truth = board.sent_frames
    for c, a0 in zip(df["counter"], df["adc0"]):
        assert truth[c][1][0] == a0
    assert 10 not in set(df["counter"])
    assert df.attrs["lost"] == 1


def test_long_segments_keep_the_host_silence_timer_alive(arm):
    """Waiting for a free queue slot must not let the board's 500 ms silence timeout fire."""
    start = arm.commanded_joints()
    segs = []
    for k in range(10):
        a = start[0] + (0.1 if k % 2 else 0.0)
        b = start[0] + (0.0 if k % 2 else 0.1)
        d0, d1 = round(math.degrees(a) * 100), round(math.degrees(b) * 100)
        rest = [round(math.degrees(v) * 100) for v in start[1:]]
        segs.append((1000, 3, [d0, 0, 3 * (d1 - d0), -2 * (d1 - d0), rest[0], 0, 0, 0, rest[1], 0, 0, 0]))
    assert arm.status().timeout == 0.5
    report = arm.run_trajectory(segs)
    assert report.queue_full_waits > 0 and report.segments == 10
    assert arm.status().flags & 0x02 == 0 and arm.port.board.executor.done == 10


def test_speed_limits_are_sent_and_checked_before_sending(arm):
    board = arm.port.board.executor
    assert board.vmax == [30000] * 3 and board.amax == [150000] * 3  # 300 deg/s, 1500 deg/s^2 (robot file)
    q = [round(math.degrees(v) * 100) for v in arm.commanded_joints()]
    fast = [(5, 3, [q[0], 0, 3000, -2000, q[1], 0, 0, 0, q[2], 0, 0, 0])]  # 10 deg in 5 ms
    sent = arm.stats.sent
    with pytest.raises(TrajectoryError, match=r"segment 0 \(5 ms\): joint 1 \(base_yaw\) exceeds.*nothing was sent"):
        arm.run_trajectory(fast)
    assert arm.stats.sent == sent and board.segments == [] and board.done == 0
    # the board refuses the same segment on its own (a host that skips the check)
    with pytest.raises(CommandRejected, match="11 SPEED joint 0") as exc:
        arm._transact("SEG", *fast[0][:2], *fast[0][2])
    assert exc.value.code == 11 and board.done == 0 and board.segments == []
    report = arm.run_trajectory([(1000, 3, [q[0], 0, 3000, -2000, q[1], 0, 0, 0, q[2], 0, 0, 0])])
    assert report.segments == 1 and board.done == 1


@pytest.mark.parametrize("call, match", [
    (lambda arm: arm.grip(float("nan")), "expected us as a finite number, got nan"),
    (lambda arm: arm.grip("open"), "expected us as a number"),
    (lambda arm: arm.set_host_timeout(float("nan")), "expected seconds as a finite number, got nan"),
    (lambda arm: arm.set_host_timeout(0.01), r"expected seconds 0 \(off\) or 0.05..60 s, got 0.01"),
    (lambda arm: arm.set_host_timeout(-1), r"expected seconds in 0..60 s, got -1"),
    (lambda arm: arm.stream(-1), "expected a recording time duration > 0 s, got -1"),
    (lambda arm: arm.stream(float("inf")), "expected duration as a finite number"),
    (lambda arm: arm.stream(1.0, hz=float("nan")), "expected hz as a finite number"),
    (lambda arm: arm.stream(1.0, hz=50.5), "expected hz as a whole number"),
])
def test_bad_arguments_are_refused_before_anything_is_sent(arm, call, match):
    sent = arm.stats.sent
    with pytest.raises(OptionError, match=match):
        call(arm)
    assert arm.stats.sent == sent


def test_move_joints_runs_the_shortest_move_the_speed_limits_allow(arm):
    """Issue 13: MOVE carries a duration; the host picks the shortest one the robot file's limits allow."""
    from labkit.arm.link._segments import move_duration_ms, move_segment
    from labkit.arm._segment_check import segment_speed_ok

    board = arm.port.board.executor
    sent = []
    orig = board._cmd_move
    board._cmd_move = lambda args: (sent.append(list(args)), orig(args))[1]
    start = [int(round(v)) for v in board.q]
    arm.move_joints(np.radians([20.0, 30.0, 40.0]))
    (*target, dur), = sent
    assert target == [2000, 3000, 4000]
    vmax, amax = arm.speed_limits()
    # independent figure: the cubic's peak speed 1.5 |dq| / T and acceleration 6 |dq| / T^2
    t_min = max(max(1.5 * abs(b - a) / v if v else 0.0, math.sqrt(6 * abs(b - a) / ac) if ac else 0.0)
                for a, b, v, ac in zip(start, target, vmax, amax))
    assert dur == move_duration_ms(start, target, vmax, amax) and t_min * 1000 <= dur <= t_min * 1000 + 2
    _, _, coef = move_segment(start, target, dur - 1)
    assert not all(segment_speed_ok(coef[4 * j:4 * j + 4], dur - 1, vmax[j], amax[j]) for j in range(3))
    # the call returned after the move: the board is idle at the target
    st = arm.status()
    assert st.state == "IDLE" and [round(math.degrees(v) * 100) for v in st.q] == target


def test_move_joints_with_a_too_short_duration_sends_nothing(arm):
    arm.move_joints(np.radians([20.0, 30.0, 40.0]))
    last = arm.status().last
    with pytest.raises(TrajectoryError, match=r"joint 1 \(base_yaw\) exceeds"):
        arm.move_joints(np.radians([120.0, 30.0, 40.0]), duration=0.05)
    assert arm.status().last == last
    with pytest.raises(OptionError, match="duration"):
        arm.move_joints(np.radians([120.0, 30.0, 40.0]), duration=float("nan"))
    arm.move_joints(np.radians([120.0, 30.0, 40.0]), duration=2.0)
    st = arm.status()
    assert st.state == "IDLE" and st.last > last
    np.testing.assert_allclose(st.q, np.radians([120.0, 30.0, 40.0]), atol=1e-4)


def test_a_raw_out_of_speed_move_is_refused_and_nothing_moves(arm):
    """The board's own check, bypassing the host's: ERR 11 SPEED and the position unchanged."""
    board = arm.port.board.executor
    before = list(board.q)
    line = "#900 MOVE 17000 9000 9000 20 "
    board.receive(f"{line}*{checksum(line):08X}\n".encode())
    out = board.take_output().decode()
    assert out.startswith("ERR #900 11 SPEED joint 0*"), out
    board.advance(0.1)
    assert board.q == before and board.state == "IDLE" and not board.segments


def test_the_robot_comes_first_and_a_sim_url_may_name_it():
    from labkit.exceptions import OptionError, PortURLError

    with Arm(None, "sim://al5d?clock=lockstep&seed=0&calibrated=1", timeout=0.05) as arm:  # the URL's robot
        assert arm.robot.name == "al5d" and arm.virtual_model.robot.name == "al5d"
    with Arm("al5d", "sim://?clock=lockstep&seed=0&calibrated=1", timeout=0.05) as arm:  # the arm's robot, simulated
        assert arm.virtual_model.robot.name == "al5d" and arm.info.joints == 5
    with pytest.raises(OptionError, match="expected the arm's robot .* got robot=None and port 'sim://\\?seed=0'"):
        Arm(None, "sim://?seed=0")
    with pytest.raises(OptionError, match="got robot=None and port '/dev/ttyACM0'"):
        Arm(None, "/dev/ttyACM0")
    with pytest.raises(PortURLError, match="expected a robot, named in the URL .* or given as the robot= option"):
        serial.serial_for_url("sim://?clock=lockstep")
