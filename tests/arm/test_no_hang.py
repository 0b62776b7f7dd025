"""Issue 27: the host never hangs and never aborts the interpreter (probes kept as tests).

- a board flooding the line (bytes always waiting) cannot hold ``Arm(robot, port)`` forever;
- a large write to ``simavr://?clock=lockstep`` returns (the simulator takes the bytes at the baud rate);
- a ``simavr://`` port or ``Arm("arduino_arm_3dof", "simavr://")`` left open ends the interpreter cleanly (exit status 0);
- a ``sim://`` lockstep read with ``timeout=None`` and nothing to read fails instead of spinning;
- a request resent under the same ``#seq`` after a lost reply is answered, not run again.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial

from labkit.arm import Arm, PortWrapper
from labkit.arm.urlhandler import register
from labkit.exceptions import DeviceError

register()
ROOT = Path(__file__).resolve().parents[2]


class Flood(PortWrapper):
    """A board that never stops sending: garbage always waiting, more than the host can read."""

    def __init__(self, port):
        super().__init__(port)
        self.read_bytes = 0

    @property
    def in_waiting(self):
        return 1 << 20

    def read(self, size=1):
        self._port.sleep(size * 10 / 115200 / 100)  # 100 MB/s of board time... 100x the baud rate
        self.read_bytes += size
        return (b"FB 1 2 3 4 5 6*0000\n" * (size // 20 + 1))[:size]


def test_a_flooding_board_does_not_hang_the_handshake():
    flood = Flood(serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.05))
    t0 = time.monotonic()
    with pytest.raises(DeviceError):
        Arm("arduino_arm_3dof", flood, timeout=0.02, retries=1, boot_wait=0.2)
    assert time.monotonic() - t0 < 20
    assert flood.read_bytes > 10_000  # it really was flooded


def test_a_lockstep_sim_read_without_timeout_fails_instead_of_spinning():
    port = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.5)
    port.readline()  # READY
    port.timeout = None
    t0 = time.monotonic()
    with pytest.raises(serial.SerialException, match="timeout=None"):
        port.read(1)
    assert time.monotonic() - t0 < 60
    port.close()


def test_a_resent_request_runs_once():
    # the reply to the first SEG is lost: the host resends it under the same #seq, the board answers it again
    raw = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.05)
    with Arm("arduino_arm_3dof", raw, timeout=0.02) as arm:
        arm.set_host_timeout(0)
        board = raw.board.executor
        emit, lost = board._emit, []

        def lose_first_seg_reply(text):
            if " SEG " in text and not lost:
                lost.append(text)
                return
            emit(text)

        board._emit = lose_first_seg_reply
        q = arm.commanded_joints()
        c = [int(round(v * 18000 / 3.141592653589793)) for v in q]
        arm._transact("SEG", 500, 3, *[x for cj in c for x in (cj, 0, 0, 0)])
        assert lost and len(board.segments) == 1  # queued once, acknowledged by the repeat's reply


@pytest.mark.firmware
@pytest.mark.xdist_group("firmware")
@pytest.mark.parametrize("size", [4096, 16384, 40000])
def test_a_large_lockstep_write_to_simavr_returns(size):
    port = serial.serial_for_url("simavr://?clock=lockstep", timeout=0.5)
    try:
        assert port.readline().startswith(b"READY")
        t0 = time.monotonic()
        assert port.write(b"x" * (size - 1) + b"\n") == size
        assert port.readline().startswith(b"ERR 4 TOOLONG")
        port.write(b"HELLO\n")
        assert port.readline().startswith(b"OK HELLO")
        assert time.monotonic() - t0 < 60
    finally:
        port.close()


@pytest.mark.firmware
@pytest.mark.xdist_group("firmware")
@pytest.mark.parametrize("how", ["port", "arm", "collected"])
def test_a_simavr_port_left_open_exits_cleanly(how):
    code = {
        "port": "p = serial.serial_for_url('simavr://?clock=lockstep', timeout=0.5); p.readline()",
        "arm": "a = Arm('arduino_arm_3dof', 'simavr://?clock=lockstep'); a.ping()",
        "collected": "p = serial.serial_for_url('simavr://?clock=lockstep', timeout=0.5); p.readline(); del p; "
                     "import gc; gc.collect()",
    }[how]
    script = ("import serial\nfrom labkit.arm import Arm\nfrom labkit.arm.urlhandler import register\n"
              f"register()\n{code}\nprint('done')\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0 and "Fatal Python error" not in proc.stderr, (proc.returncode, proc.stderr[-2000:])
    assert proc.stdout.strip() == "done"


BAD = [float("nan"), float("inf"), -1.0, 1e308, "x", None, [1.0, 2.0], True]


@pytest.fixture(scope="module")
def sim_arm():
    with Arm("arduino_arm_3dof", "sim://?clock=lockstep", timeout=0.02) as arm:
        yield arm


@pytest.mark.parametrize("value", BAD, ids=repr)
@pytest.mark.parametrize("call", ["sleep", "wait_settled tol", "wait_settled max_wait", "Arm timeout", "Arm retries",
                                  "Arm boot_wait", "grip", "set_host_timeout", "move_joints"])
def test_bad_arm_arguments_are_labkit_errors_and_never_wait_forever(sim_arm, call, value):
    from labkit.exceptions import LabkitError  # noqa: F401 - caught below

    run = {
        "sleep": lambda: sim_arm.sleep(value),
        "wait_settled tol": lambda: sim_arm.wait_settled(sim_arm.commanded_joints(), tol=value, max_wait=0.1),
        "wait_settled max_wait": lambda: sim_arm.wait_settled(sim_arm.commanded_joints(), max_wait=value),
        "Arm timeout": lambda: Arm("arduino_arm_3dof", "sim://?clock=lockstep", timeout=value).close(),
        "Arm retries": lambda: Arm("arduino_arm_3dof", "sim://?clock=lockstep", retries=value).close(),
        "Arm boot_wait": lambda: Arm("arduino_arm_3dof", "sim://?clock=lockstep", boot_wait=value).close(),
        "grip": lambda: sim_arm.grip(value),
        "set_host_timeout": lambda: sim_arm.set_host_timeout(value),
        "move_joints": lambda: sim_arm.move_joints([value, 1.0, 1.0]),
    }[call]
    t0 = time.monotonic()
    try:  # a value that makes sense (a huge tolerance, True as 1 rad) may be accepted; nothing else may come
        run()
    except LabkitError:
        pass
    assert time.monotonic() - t0 < 30
