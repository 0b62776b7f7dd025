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
from labkit.arm._protocol import echo, seal

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
    body, _, hhhh = line.rpartition("*")
    assert len(hhhh) == 8 and int(hhhh, 16) == checksum(body), line
    return body


_SEQ = [100]


def cmd(board, line):
    """Send ``line`` sealed (``#seq`` and CRC, as state-changing commands must be); return the reply bodies
    with the CRC, the ``#seq`` and a correct echo removed (``"OK MOVE"``, ``"ERR 6 LIMIT ..."``)."""
    _SEQ[0] += 1
    seq = _SEQ[0]
    out = []
    for ln in talk(board, seal(f"#{seq} {line} ")):
        body = strip(ln).replace(f" #{seq}", "", 1)
        words = line.split()
        want = echo(words[0], [int(w) for w in words[1:]]) if body.startswith("OK") else None
        if want and body.split()[2:3] == [want]:
            body = body.replace(f" {want}", "", 1)
        out.append(body)
    return out


def move(board, q, dur_ms=250):
    """``MOVE q dur_ms`` (a rest-to-rest cubic) run to its end."""
    assert cmd(board, f"MOVE {q} {dur_ms}") == ["OK MOVE 5"]
    board.advance(dur_ms / 1000 + 0.05)
    assert [strip(x) for x in board.take_output().decode().split("\r\n") if x][-1].startswith("EV DONE ")
    assert "state=IDLE" in talk(board, "STATUS")[0]


def test_ready_line_and_hello_match_the_protocol_examples():
    b = VirtualBoard("arduino_arm_3dof")
    b.advance_to(0.05)
    assert b.take_output() == b""
    b.advance_to(0.2)
    assert b.take_output() == b"READY labkit-arm 3 fw=3.0.0 proto=3 joints=3 reset=POWER eeprom=DEFAULTS*8B079DC6\r\n"
    assert talk(b, "HELLO") == ["OK HELLO labkit-arm fw=3.0.0 proto=3 joints=3 channels=4 queue=6 maxline=164*BA094EC5"]


def test_example_session_lines_and_checksums():
    b = booted()
    assert talk(b, "#1 MOVE 4500 19000 3000 1000 *957893A0") == ["ERR #1 6 LIMIT joint 1*5B92339F"]
    assert talk(b, "#2 MOVE 4500 9000 3000 50 *DE0686EC") == ["ERR #2 11 SPEED joint 0*8E3CE42C"]
    assert talk(b, "#3 MOVE 4500 9000 3000 1000 *D4CB5EC6") == ["OK #3 MOVE p=AE3CFF72 5*4CC173D6"]
    assert talk(b, "#3 PING*XXXX") == ["ERR 1 BADCHK malformed*1C401CB2"]
    assert talk(b, "FLY") == ["ERR 3 UNKNOWN*F1DCDF7E"]
    assert talk(b, "#4 ping")[0].startswith("OK #4 PING ")
    assert talk(b, "  $#5 PING*12  ")[0].startswith("ERR 1 BADCHK malformed")  # two hex digits: protocol 1
    assert talk(b, "  $#5 PING*A94D  ")[0].startswith("ERR 1 BADCHK malformed")  # four: protocol 2's CRC-16
    assert talk(b, f"$#5 PING*{checksum('#5 PING') ^ 1:08X}")[0].startswith("ERR 1 BADCHK mismatch")
    assert talk(b, f"$#5 PING*{checksum('#5 PING'):08x}")[0].startswith("OK #5 PING")


def test_state_changing_lines_need_seq_and_crc():
    b = booted()
    before = list(b.executor.q)
    for line in ["MOVE 4500 9000 3000 250", "#5 MOVE 4500 9000 3000 250", seal("MOVE 4500 9000 3000 250 "),
                 "GRIP 1200", "TIMEOUT 0", "STREAM 10", "SAVE", "DEFAULTS", "STOP", "CAL 0"]:
        assert talk(b, line) == [seal("ERR 1 BADCHK unsealed")], line
    ex = b.executor
    assert ex.q == before and ex.grip == 1500 and ex.stream_hz == 0 and ex.timeout_ms == 500


def test_the_line_split_attack_of_issue_13_runs_nothing():
    """A byte damaged into LF splits a sealed MOVE; neither half may run (protocol 1 ran the front half)."""
    b = booted()
    before = list(b.executor.q)
    line = seal("#5 MOVE 4500 9000 3000 250 ")
    for k in range(1, len(line)):
        for eol in (b"\n", b"\r"):
            b.receive(line[:k].encode() + eol + line[k + 1:].encode() + b"\n")
            out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
            assert not any(o.startswith("OK") for o in out), (k, out)
    assert b.executor.q == before


def test_lines_without_reply_and_malformed_lines():
    b = booted()
    assert talk(b, "   ") == []
    assert cmd(b, "MOVE 1 2 3")[0].startswith("ERR 2 SYNTAX")  # the duration is required
    assert strip(talk(b, "#99999 PING")[0]).startswith("ERR 2 SYNTAX")
    assert cmd(b, "MOVE 1 2 3 x")[0].startswith("ERR 2 SYNTAX")
    assert cmd(b, "MOVE -2147483648 0 0 250")[0].startswith("ERR 2 SYNTAX")  # int32 without its minimum
    assert strip(talk(b, "#1 PING*4")[0]) == "ERR 1 BADCHK malformed"
    b.receive(b"PI\xffNG\n")
    assert strip(b.take_output().decode().strip()).startswith("ERR 2 SYNTAX")
    assert strip(talk(b, "PING " + "1" * 200)[0]).startswith("ERR 4 TOOLONG")
    assert " flags=11 " in talk(b, "STATUS")[0]  # EEPROM defaults + a line too long
    assert strip(talk(b, "$")[0]) == "ERR 2 SYNTAX command"
    assert strip(talk(b, "*FFFFFFFF")[0]) == "ERR 1 BADCHK mismatch"


def test_every_request_gets_exactly_one_reply_in_order():
    b = booted()
    b.receive(b"#1 PING\r\n#2 STATUS\r#3 HELLO\n\n#4 READ\n")
    lines = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert [ln.split()[1] for ln in lines] == ["#1", "#2", "#3", "#4"]


def test_move_updates_commanded_position_and_physics_follows():
    b = booted(zero_offsets=(0, 0, 0), feedback_noise=0.0)
    assert cmd(b, "MOVE 4500 9000 3000 250") == ["OK MOVE 5"]
    st = strip(talk(b, "STATUS")[0])
    assert "q=9000,9000,9000" in st and "state=RUN" in st  # a rest-to-rest cubic from the boot position
    b.advance(0.14)
    q0 = int(strip(talk(b, "STATUS")[0]).split()[3].split("=")[1].split(",")[0])
    assert 4500 < q0 < 6750  # past half way (s = 0.56)
    b.advance(0.16)
    out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert out == ["EV DONE 1"]
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
    cmd(b, "TIMEOUT 0")
    move(b, "4500 9000 3000")
    assert cmd(b, "SEG 1000 3 4500 0 13500 -9000 9000 0 0 0 3000 0 0 0")[0] == "OK SEG 5"
    assert cmd(b, "SEG 1000 3 9000 0 -13500 9000 9000 0 0 0 3000 0 0 0")[0] == "OK SEG 4"
    b.advance(0.5)
    st = strip(talk(b, "PING")[0])  # keep the host-silence timer alive
    q = int(strip(talk(b, "STATUS")[0]).split()[3].split("=")[1].split(",")[0])
    assert 6000 < q < 7500  # half way up the first cubic
    b.advance(1.6)
    out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert out == ["EV DONE 3"]  # the MOVE counts as one segment
    assert "q=4500,9000,3000" in strip(talk(b, "STATUS")[0])
    assert st.startswith("OK PING")


def test_segment_checks():
    b = booted()
    move(b, "4500 9000 3000")
    assert "ERR 5 RANGE" in cmd(b, "SEG 0 3 4500 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 5 RANGE" in cmd(b, "SEG 100 4 4500 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 2 SYNTAX" in cmd(b, "SEG 100 3 4500 0 0 0 9000 0 0 0 3000 0 0")[0]
    assert "ERR 6 LIMIT" in cmd(b, "SEG 100 3 4500 0 -10000 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 9 DISCONT" in cmd(b, "SEG 100 3 4600 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "OK SEG 5" in cmd(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    assert "ERR 8 BUSY" in cmd(b, "MOVE 0 0 0 1000")[0]
    for k in range(5):
        assert cmd(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0].startswith(f"OK SEG {4 - k}")
    assert "ERR 7 QFULL" in cmd(b, "SEG 100 3 4549 0 0 0 9000 0 0 0 3000 0 0 0")[0]
    stop = (cmd(b, "STOP")[0])
    assert stop == "OK STOP 4500 9000 3000"  # last sample: no servo frame ran yet
    assert "queue=0" in talk(b, "STATUS")[0]


def test_host_silence_timeout_holds():
    b = booted()
    cmd(b, "TIMEOUT 100")
    cmd(b, "SEG 2000 3 9000 0 1000 0 9000 0 0 0 9000 0 0 0")
    b.advance(0.3)
    out = [strip(x) for x in b.take_output().decode().split("\r\n") if x]
    assert out[0].startswith("EV HOLD ")
    st = strip(talk(b, "STATUS")[0])
    assert "state=HOLD" in st and "flags=03" in st
    assert cmd(b, "MOVE 9000 9000 9000 20")[0].startswith("OK MOVE")
    assert "state=RUN" in talk(b, "STATUS")[0]
    b.advance(0.1)
    assert [strip(x) for x in b.take_output().decode().split("\r\n") if x] == ["EV DONE 1"]
    assert "state=IDLE" in talk(b, "STATUS")[0]
    assert "ERR 5 RANGE" in cmd(b, "TIMEOUT 20")[0]


def test_stream_frames_counter_and_clock():
    b = booted()
    assert (cmd(b, "STREAM 100")[0]) == "OK STREAM 100"
    b.advance(0.1)
    frames = [strip(x).split() for x in b.take_output().decode().split("\r\n") if x]
    assert [int(f[1]) for f in frames] == list(range(len(frames)))
    t = [int(f[2]) for f in frames]
    assert np.all(np.diff(t) == 10) and len(frames) in (10, 11)
    assert all(len(f) == 3 + 3 + 1 for f in frames)
    assert (cmd(b, "STREAM 0")[0]) == "OK STREAM 0"
    b.advance(0.1)
    assert b.take_output() == b""
    assert "ERR 5 RANGE" in cmd(b, "STREAM 201")[0]


def test_calibration_save_survives_reset():
    b = booted()
    assert cmd(b, "CAL 2 600 2400 18000 -1 0 17000") == ["OK CAL 2 600 2400 18000 -1 0 17000"]
    assert cmd(b, "SAVE") == ["OK SAVE 78"]  # EEPROM image version 3 (with the speed limits, sealed with a CRC-32)
    b.reset()
    b.advance(0.2)
    assert b"reset=EXTERNAL eeprom=OK" in b.take_output()
    assert (cmd(b, "CAL 2")[0]) == "OK CAL 2 600 2400 18000 -1 0 17000"
    assert "flags=00" in talk(b, "STATUS")[0]
    assert "ERR 5 RANGE" in cmd(b, "CAL 9")[0]
    assert "ERR 6 LIMIT" in cmd(b, "CAL 0 500 2500 0 1 0 1000")[0]  # joint 0 sits at 9000
    assert cmd(b, "DEFAULTS")[0].startswith("OK DEFAULTS")
    b.executor.eeprom[10] ^= 0xFF  # corrupt the image: CRC fails at the next boot
    b.reset()
    b.advance(0.2)
    assert b"eeprom=DEFAULTS" in b.take_output()


def test_gripper_range():
    b = booted()
    assert (cmd(b, "GRIP 1200")[0]) == "OK GRIP 1200"
    assert "ERR 5 RANGE" in cmd(b, "GRIP 3000")[0]
    assert "grip=1200" in talk(b, "STATUS")[0]


def test_url_handler_options_and_errors():
    port = serial.serial_for_url("sim://arduino_arm_3dof?seed=3&clock=lockstep&deadband=0&zero_offsets=0.01,0,0",
                                 timeout=0.5)
    assert port.board.model.zero_offsets[0] == 0.01
    assert port.board.config.deadband == 0.0
    assert port.readline().startswith(b"READY labkit-arm 3 ")
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
    port = serial.serial_for_url("sim://arduino_arm_3dof?time_scale=20", timeout=0.2)
    t0 = time.monotonic()
    assert port.readline().startswith(b"READY")
    assert time.monotonic() - t0 < 0.1  # 0.1 s of board time is 5 ms of wall time
    time.sleep(0.05)
    port.write(b"PING\n")
    t_board = int(port.readline().split()[2].split(b"*")[0]) / 1000
    assert t_board >= 0.9
    port.close()


@pytest.mark.slow
def test_labkit_sim_serves_a_pty():
    proc = subprocess.Popen([sys.executable, "-m", "labkit", "sim", "arduino_arm_3dof", "--seed", "2"], stdout=subprocess.PIPE,
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
    from labkit.arm.board._board import VirtualBoard, calibration_rows
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
    assert board.executor.cal == rows and not board.executor.flags & 0x01
    assert all(r[4] <= q <= r[5] for q, r in zip(board.executor.q, rows))
    with pytest.raises(LabkitError, match="CAL rejected: 6 LIMIT"):
        Arm(str(path), f"sim://{path}?clock=lockstep")
    with Arm(str(path), f"sim://{path}?clock=lockstep&calibrated=1") as arm:
        q = np.radians([10, 60, -120, 20, 30, 40])
        arm.move_joints(q, wait=True)
        assert np.abs(arm.read_joints() - q).max() < np.radians(1.5)


def test_the_eeprom_image_is_sealed_with_the_line_crc32():
    from labkit.arm.board._commands import FACTORY, eeprom_image, read_eeprom

    cal = [list(FACTORY) for _ in range(4)]
    cal[2] = [600, 2400, 18000, -1, 0, 17000]
    img = eeprom_image(cal, [60000] * 3, [0] * 3, 1500)
    # firmware/tests/test_core.c checks that the firmware's image of the same settings ends with the same CRC
    assert len(img) == 78 and img[2] == 3 and int.from_bytes(img[-4:], "little") == checksum(img[:-4]) == 0xA63237F5
    assert read_eeprom(img, 4) == (cal, [60000] * 3, [0] * 3, 1500, True)
    for k in range(len(img)):  # any damaged byte: the factory defaults
        bad = bytearray(img)
        bad[k] ^= 0x10
        assert read_eeprom(bytes(bad), 4)[-1] is False, k
