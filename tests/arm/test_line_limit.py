"""The protocol's line limit (``MAX_LINE``) bounds the joints of an arm and the width of every request.

A request longer than 164 bytes is discarded by the board as garbled (``ERR 4``) however often it is sent, so
the host measures every sealed line before sending it and refuses one too long (nothing sent, nothing
numbered, the arm still); an arm with more joints than the widest request can carry is refused before its
port is opened, and ``labkit new`` writes no lab for it.
"""

import numpy as np
import pytest

from labkit.exceptions import OptionError, RobotError


def chain_robot(n):
    """A robot file of ``n`` revolute joints without servo tables (ideal actuators on the virtual arm)."""
    text = ('format = "labkit-robot/1"\n'
            f'name = "chain{n}"\ntitle = "{n}-joint chain (test only)"\nconvention = "standard"\n'
            'units = { length = "mm", angle = "deg" }\n')
    for i in range(n):
        shape = "d = 80\nalpha = 90\n" if i == 0 else f"a = {100 - 5 * i}\n"
        text += f'\n[[joint]]\nname = "j{i}"\n{shape}limits = [-150, 150]\n'
    return text


@pytest.fixture
def chain_file(tmp_path):
    def make(n):
        path = tmp_path / f"chain{n}.toml"
        path.write_text(chain_robot(n))
        return str(path)

    return make


def test_joint_limit_is_the_widest_request_that_fits():
    from labkit.arm import MAX_JOINTS, MAX_LINE, max_joints
    from labkit.arm._protocol import seal

    def seg_line(joints, order):  # joints held still at -32000, widest seq and duration, as labkit writes it
        return seal("#65535 SEG 60000 %d " % order + "".join(f"-32000 {'0 ' * order}" for _ in range(joints)))

    for order in (3, 5):
        k = max_joints("SEG", order)
        assert len(seg_line(k, order)) <= MAX_LINE < len(seg_line(k + 1, order)), order
    k = max_joints("MOVE")
    move = lambda j: seal("#65535 MOVE " + "-32000 " * j + "60000 ")  # noqa: E731
    assert len(move(k)) <= MAX_LINE < len(move(k + 1))
    assert MAX_JOINTS == max_joints("SEG", 5) == 8 and max_joints("SEG", 3) == 10 and max_joints("MOVE") == 19


def test_protocol_doc_states_the_joint_limit():
    from pathlib import Path

    from labkit.arm import MAX_JOINTS

    text = (Path(__file__).parents[2] / "docs" / "protocol.md").read_text(encoding="utf-8")
    assert f"Joints a line can carry: at most {MAX_JOINTS}." in text and f"**J <= {MAX_JOINTS}**" in text


@pytest.mark.parametrize("port", ["sim://?clock=lockstep", "sim://?bus=dynamixel", "/dev/ttyACM0", None])
def test_an_arm_with_more_joints_than_a_line_carries_is_refused_before_opening(chain_file, monkeypatch, port):
    from labkit.arm import Arm

    def no_open(*args, **kwargs):
        raise AssertionError("the port must not be opened")

    monkeypatch.setattr(Arm, "_open", staticmethod(no_open))
    path = chain_file(10)
    with pytest.raises(RobotError) as info:
        Arm(path, port)
    text = str(info.value)
    assert "chain10" in text and path in text and "10 joints" in text and "at most 8" in text and "164" in text


def _wire_for(robot_file):
    """A wire to a virtual board of ``robot_file``'s joints (bypassing Arm, which refuses such a robot)."""
    from labkit.arm.link._ports import open_port
    from labkit.arm.urlhandler import register
    from labkit.arm.link._wire import Wire
    from labkit.robot import Robot

    register()
    wire = Wire(open_port("sim://?clock=lockstep", 115200, Robot.load(robot_file)), name="sim", timeout=0.25,
                retries=6)
    assert wire.wait_ready(3.0) is not None
    return wire


def _status(wire):
    return dict(t.split("=", 1) for t in wire.transact("STATUS").tokens[2:] if "=" in t)


def test_a_too_long_request_sends_nothing_and_names_command_values_length_and_limit(chain_file):
    from labkit.arm._protocol import seal

    wire = _wire_for(chain_file(10))
    try:
        before = _status(wire)
        written = []
        real_write = wire.port.write
        wire.port.write = lambda data: (written.append(bytes(data)), real_write(data))[1]
        seq, sent = wire._seq, wire.stats.sent
        coef = [-9000, 0, 27000, -18000] * 10  # a 10-joint cubic
        length = len(seal(f"#{seq + 1} SEG 5000 3 " + "-9000 0 27000 -18000 " * 10))  # the line it would be
        assert length > 164
        with pytest.raises(OptionError) as info:
            wire.transact("SEG", 5000, 3, *coef, motion=True, verify=lambda s: False)
        text = str(info.value)
        assert "SEG with 42 values" in text and f"{length}-byte" in text and "limit of 164 bytes" in text
        assert "nothing was sent" in text and "at most 10 joints" in text and "shorter segments" in text
        assert written == [] and wire.stats.sent == sent and wire._seq == seq
        wire.port.write = real_write
        after = _status(wire)  # the board saw no line: no ERR 4 flag, nothing run, nothing moved
        assert after["flags"] == before["flags"] and int(after["flags"], 16) & 0x10 == 0
        assert after["last"] == before["last"] and after["q"] == before["q"] and after["state"] == "IDLE"
    finally:
        wire.close()


def test_seven_joints_run_a_trajectory_and_a_too_wide_segment_is_refused_whole(chain_file):
    from labkit.arm import Arm
    from labkit.motion import joint_trajectory

    with Arm(chain_file(7), "sim://?clock=lockstep") as arm:
        q0 = arm.commanded_joints()
        q1 = q0 - 0.4
        report = arm.run_trajectory(joint_trajectory(arm.robot, q0, q1, 1.0, dt=0.01))
        assert report.segments > 1 and report.retries == 0
        assert np.allclose(arm.commanded_joints(), q1, atol=1e-3)
        # a rest-to-rest cubic over 180 deg on every joint: 7 x 4 coefficients need a 168-byte line
        start = arm._units.positions(q1)
        coef = [v for p in start for v in (p, 0, 3 * (-2 * p), -2 * (-2 * p))]  # to -p
        segs = [(2000, 3, [v for p in start for v in (p, 0, 0, 0)]), (5000, 3, coef)]
        sent, events = arm.stats.sent, len(arm.events)
        with pytest.raises(OptionError, match=r"segment 1 of 2 \(5000 ms\): SEG with 30 values would be a 1\d\d-byte"):
            arm.run_trajectory(segs)
        assert arm.stats.sent == sent and len(arm.events) == events, "not even the first segment was sent"
        assert np.allclose(arm.commanded_joints(), q1, atol=1e-3)


def test_an_eight_joint_status_longer_than_a_request_line_round_trips(chain_file):
    """STATUS is the one board line longer than MAX_LINE (``docs/protocol.md`` 2.2): the host reads and parses it."""
    from labkit.arm import Arm

    with Arm(chain_file(8), "sim://?clock=lockstep") as arm:
        target = np.radians(np.linspace(-140.0, -147.0, 8))  # -14000 .. -14700 cdeg: six characters a joint
        arm.move_joints(target, wait=True)
        board = arm.port.board
        sent, take = [], board.take_output
        board.take_output = lambda size=None: (out := take(size), sent.append(out))[0]
        bad, retries = arm.stats.bad_lines, arm.stats.retries
        st = arm.status()
        lines = b"".join(sent).split(b"\r\n")
        status = [ln for ln in lines if b" STATUS state=" in ln]
        assert len(status) == 1 and len(status[0]) > 164, status
        np.testing.assert_array_equal(arm._units.positions(st.q), arm._units.positions(target))
        assert st.state == "IDLE" and st.queue + st.free == arm.info.queue
        assert arm.stats.bad_lines == bad and arm.stats.retries == retries


def test_the_widest_status_is_as_long_as_the_host_reckons(chain_file):
    from labkit.arm import Arm
    from labkit.arm._protocol import seal, unseal
    from labkit.arm.link._replies import longest_status, parse_status

    with Arm(chain_file(8), "sim://?clock=lockstep") as arm:
        ex = arm.port.board.executor
        ex.take_output()
        ex.q = [-32000.0] * 8
        ex.state, ex.done, ex.timeout_ms, ex.stream_hz, ex.flags, ex.mem = "HOLD", 2**32 - 1, 60000, 200, 0xFF, 65535
        ex.grip, ex.last_seq = 2600, 65535
        ex.boot_time, ex.time = 0.0, (2**32 - 0.5) / 1000
        ex.receive((seal("#65535 STATUS ") + "\r\n").encode())
        line = ex.take_output().rstrip(b"\r\n")
    assert len(line) == longest_status(8) == 203 > 164
    tokens = unseal(line).decode().split()
    st = parse_status(tokens[3:], 8)
    assert tokens[:3] == ["OK", "#65535", "STATUS"] and st.t == pytest.approx(4294967.295) and st.done == 2**32 - 1


def test_a_lockstep_reply_wait_covers_the_longest_status():
    """On a lockstep board a reply not begun within its wire-time bound is taken as lost: the bound must cover the
    longest board line, an 8-joint STATUS (203 bytes), not a request line's 164."""
    from labkit.arm import MAX_JOINTS, Arm
    from labkit.arm._protocol import request_length
    from labkit.arm.link._replies import longest_status
    from labkit.arm.link._wire import _BOARD_REPLY_S

    byte_s = 10 / 115200
    with Arm("arduino_arm_3dof", "sim://?clock=lockstep", timeout=1.0) as arm:
        assert arm.port.clock == "lockstep"
        request = request_length("STATUS", []) + 1  # with its end of line
        assert arm._wire.reply_wait("STATUS", request) >= ((request + longest_status(MAX_JOINTS) + 2) * byte_s
                                                           + _BOARD_REPLY_S)
