"""Tests of the virtual arm (labkit.arm) against docs/protocol.md, and of the sim:// URL handler."""

import math
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from labkit.arm import PhysicsConfig
from labkit.arm import VirtualBoard, checksum
from labkit.arm.urlhandler import register

register()


def booted(**kw):
    b = VirtualBoard("arduino_arm_3dof", PhysicsConfig(**kw))
    b.advance_to(0.2)
    b.take_output()
    return b


def talk(board, line):
    board.receive(line.encode() + b"\n")
    return [ln for ln in board.take_output().decode().split("\r\n") if ln]


def strip(line):
    body, _, hh = line.rpartition("*")
    assert int(hh, 16) == checksum(body), line
    return body


def test_boot_event_and_hello_match_the_protocol_examples():
    b = VirtualBoard()
    b.advance_to(0.05)
    assert b.take_output() == b""
    b.advance_to(0.2)
    assert b.take_output() == b"EV BOOT labkit-arm fw=1.0.0 proto=1 reset=POWER eeprom=DEFAULTS*1A\r\n"
    assert talk(b, "HELLO") == ["OK HELLO labkit-arm fw=1.0.0 proto=1 joints=3 channels=4 queue=6 maxline=160*73"]


def test_example_session_lines_and_checksums():
    b = booted()
    assert talk(b, "#1 MOVE 4500 9000 3000*08") == ["OK #1 MOVE*07"]
    assert talk(b, "#2 MOVE 4500 19000 3000") == ["ERR #2 6 LIMIT joint 1 19000 outside 0..18000*34"]
    assert talk(b, "#3 PING*XX") == ["ERR 1 BADCHK*73"]
    assert talk(b, "FLY") == ["ERR 3 UNKNOWN FLY*4D"]
    assert talk(b, "#4 ping") [0].startswith("OK #4 PING ")
    assert talk(b, "  $#5 PING*12  ")[0].startswith("ERR 1 BADCHK")  # XOR of "#5 PING" is 0x22
    assert talk(b, f"$#5 PING*{checksum('#5 PING'):02X}")[0].startswith("OK #5 PING")


def test_lines_without_reply_and_malformed_lines():
    b = booted()
    assert talk(b, "   ") == []
    assert strip(talk(b, "#1 MOVE 1 2")[0]).startswith("ERR #1 2 SYNTAX")
    assert strip(talk(b, "#99999 PING")[0]).startswith("ERR 2 SYNTAX")
    assert strip(talk(b, "#1 MOVE 1 2 x")[0]).startswith("ERR #1 2 SYNTAX")
    assert strip(talk(b, "#1 PING*4")[0]) == "ERR 1 BADCHK"
    b.receive(b"PI\xffNG\n")
    assert strip(b.take_output().decode().strip()).startswith("ERR 2 SYNTAX")
    assert strip(talk(b, "PING " + "1" * 200)[0]).startswith("ERR 4 TOOLONG")
    assert " flags=11 " in talk(b, "STATUS")[0]  # EEPROM defaults + a line too long


def test_every_request_gets_exactly_one_reply_in_order():
    b = booted()
    b.receive(b"#1 PING\r\n#2 STATUS\r#3 HELLO\n\n#4 READ\n")
    lines = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert [ln.split()[1] for ln in lines] == ["#1", "#2", "#3", "#4"]


def test_move_updates_commanded_position_and_physics_follows():
    b = booted(zero_offsets=(0, 0, 0), feedback_noise=0.0)
    talk(b, "#1 MOVE 4500 9000 3000")
    st = strip(talk(b, "STATUS")[0])
    assert "q=4500,9000,3000" in st and "state=IDLE" in st
    b.advance(2.0)
    counts = [int(v) for v in strip(talk(b, "READ")[0]).split()[2:]]
    cal = b.robot.links[0].servo
    expected = [cal.adc_from_joint(math.radians(d)) for d in (45, 90, 30)]
    np.testing.assert_allclose(counts[:3], expected, atol=2.5)
    assert counts[3] == 512


def test_segments_run_queue_and_done_event():
    b = booted()
    talk(b, "TIMEOUT 0")
    talk(b, "MOVE 4500 9000 3000")
    assert talk(b, "#10 SEG 1000 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0")[0] == "OK #10 SEG 5*62"
    assert talk(b, "#11 SEG 1000 3 9000 0 -13500 9000 9000 0 0 0 3000 0 0 0")[0] == "OK #11 SEG 4*62"
    b.advance(0.5)
    st = strip(talk(b, "PING")[0])  # keep the host-silence timer alive
    q = int(strip(talk(b, "STATUS")[0]).split()[3].split("=")[1].split(",")[0])
    assert 6000 < q < 7500  # half way up the first cubic
    b.advance(1.6)
    out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert out == ["EV DONE 2"]
    assert "q=4500,9000,3000" in strip(talk(b, "STATUS")[0])
    assert st.startswith("OK PING")


def test_segment_checks():
    b = booted()
    talk(b, "MOVE 4500 9000 3000")
    assert "ERR 5 RANGE" in talk(b, "SEG 0 3 4500 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 5 RANGE" in talk(b, "SEG 100 4 4500 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 2 SYNTAX" in talk(b, "SEG 100 3 4500 0 0 0 9000 0 0 0 3000 0 0")[0]
    assert "ERR 6 LIMIT" in talk(b, "SEG 100 3 4500 0 -10000 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 9 DISCONT" in talk(b, "SEG 100 3 4600 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "OK SEG 5" in talk(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 8 BUSY" in talk(b, "MOVE 0 0 0")[0]
    for k in range(5):
        assert talk(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0].startswith(f"OK SEG {4 - k}")
    assert "ERR 7 QFULL" in talk(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    stop = strip(talk(b, "STOP")[0])
    assert stop == "OK STOP 4500 9000 3000"  # last sample: no servo frame ran yet
    assert "queue=0" in talk(b, "STATUS")[0]


def test_host_silence_timeout_holds():
    b = booted()
    talk(b, "TIMEOUT 100")
    talk(b, "SEG 2000 3 9000 0 1000 0 9000 0 0 0 9000 0 0 0")
    b.advance(0.3)
    out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert out[0].startswith("EV HOLD ")
    st = strip(talk(b, "STATUS")[0])
    assert "state=HOLD" in st and "flags=03" in st
    assert talk(b, "MOVE 9000 9000 9000")[0].startswith("OK MOVE")
    assert "state=IDLE" in talk(b, "STATUS")[0]
    assert "ERR 5 RANGE" in talk(b, "TIMEOUT 20")[0]


def test_stream_frames_counter_and_clock():
    b = booted()
    assert strip(talk(b, "STREAM 100")[0]) == "OK STREAM 100"
    b.advance(0.1)
    frames = [strip(x).split() for x in b.take_output().decode().split("\r\n") if x]
    assert [int(f[1]) for f in frames] == list(range(len(frames)))
    t = [int(f[2]) for f in frames]
    assert np.all(np.diff(t) == 10) and len(frames) in (10, 11)
    assert all(len(f) == 3 + 3 + 1 for f in frames)
    assert strip(talk(b, "STREAM 0")[0]) == "OK STREAM 0"
    b.advance(0.1)
    assert b.take_output() == b""
    assert "ERR 5 RANGE" in talk(b, "STREAM 201")[0]


def test_calibration_save_survives_reset():
    b = booted()
    assert talk(b, "CAL 2 600 2400 18000 -1 0 17000") == ["OK CAL 2 600 2400 18000 -1 0 17000*6B"]
    assert talk(b, "SAVE") == ["OK SAVE 52*02"]
    b.reset()
    b.advance(0.2)
    assert b"reset=EXTERNAL eeprom=OK" in b.take_output()
    assert strip(talk(b, "CAL 2")[0]) == "OK CAL 2 600 2400 18000 -1 0 17000"
    assert "flags=00" in talk(b, "STATUS")[0]
    assert "ERR 5 RANGE" in talk(b, "CAL 9")[0]
    assert "ERR 6 LIMIT" in talk(b, "CAL 0 500 2500 0 1 0 1000")[0]  # joint 0 sits at 9000
    assert talk(b, "DEFAULTS")[0].startswith("OK DEFAULTS")
    b.eeprom[10] ^= 0xFF  # corrupt the image: CRC fails at the next boot
    b.reset()
    b.advance(0.2)
    assert b"eeprom=DEFAULTS" in b.take_output()


def test_gripper_range():
    b = booted()
    assert strip(talk(b, "GRIP 1200")[0]) == "OK GRIP 1200"
    assert "ERR 5 RANGE" in talk(b, "GRIP 3000")[0]
    assert "grip=1200" in talk(b, "STATUS")[0]


def test_url_handler_options_and_errors():
    port = serial.serial_for_url("sim://arduino_arm_3dof?seed=3&clock=lockstep&deadband=0&zero_offsets=0.01,0,0",
                                 timeout=0.5)
    assert port.board.model.zero_offsets[0] == 0.01
    assert port.board.config.deadband == 0.0
    assert port.readline().startswith(b"EV BOOT")
    port.write(b"PING\n")
    assert port.readline().startswith(b"OK PING")
    port.sleep(1.0)
    assert port.board.time >= 1.1
    port.close()
    with pytest.raises(serial.SerialException, match="unknown option 'colour'"):
        serial.serial_for_url("sim://?colour=red")
    with pytest.raises(serial.SerialException, match="expected clock one of realtime, lockstep"):
        serial.serial_for_url("sim://?clock=fast")
    with pytest.raises(serial.SerialException, match="unknown robot"):
        serial.serial_for_url("sim://no_such_robot")


def test_realtime_clock_runs_scaled():
    port = serial.serial_for_url("sim://?time_scale=20", timeout=0.2)
    t0 = time.monotonic()
    assert port.readline().startswith(b"EV BOOT")
    assert time.monotonic() - t0 < 0.1  # 0.1 s of board time is 5 ms of wall time
    time.sleep(0.05)
    port.write(b"PING\n")
    t_board = int(port.readline().split()[2].split(b"*")[0]) / 1000
    assert t_board >= 0.9
    port.close()


@pytest.mark.slow
def test_labkit_sim_serves_a_pty():
    proc = subprocess.Popen([sys.executable, "-m", "labkit", "sim", "--seed", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        with serial.Serial(path, 115200, timeout=2.0) as port:
            port.write(b"HELLO\n")
            lines = [port.readline() for _ in range(2)]
        assert any(ln.startswith(b"OK HELLO labkit-arm") for ln in lines)
    finally:
        proc.terminate()
        proc.wait(5)


def test_board_with_saved_calibration_accepts_a_robot_whose_limits_exclude_90_deg(tmp_path):
    """Factory EEPROM: every servo at 90 deg, so CAL of a joint limited to [-225, 45] deg is refused;
    a board that saved the robot file's calibration boots inside the limits and CAL is accepted."""
    import math

    from labkit.arm import Arm
    from labkit.arm._board import VirtualBoard, calibration_rows
    from labkit.exceptions import LabkitError
    from labkit.robot import Robot, ServoCalibration

    robot = Robot.load("puma560")
    for i, lk in enumerate(robot.links):
        lo, hi = lk.limits
        robot = robot.with_link(i, servo=ServoCalibration(channel=i, zero=math.pi / 2 - (lo + hi) / 2))
    path = tmp_path / "puma560_servos.toml"
    robot.to_toml(path)
    rows = calibration_rows(robot)
    board = VirtualBoard(str(path), saved_calibration=True)
    assert board.cal == rows and not board.flags & 0x01
    assert all(r[4] <= q <= r[5] for q, r in zip(board.q, rows))
    with pytest.raises(LabkitError, match="invalid under the new calibration"):
        Arm(f"sim://{path}?clock=lockstep", robot=str(path))
    with Arm(f"sim://{path}?clock=lockstep&calibrated=1", robot=str(path)) as arm:
        q = np.radians([10, 60, -120, 20, 30, 40])
        arm.move_joints(q, wait=True)
        assert np.abs(arm.read_joints() - q).max() < np.radians(1.5)
