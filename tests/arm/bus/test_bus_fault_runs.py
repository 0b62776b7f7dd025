"""Fault runs of a servo bus (issue 41): a byte-corrupting, byte-dropping proxy on a pseudo-terminal between the
unmodified vendor SDK and the virtual bus, bytes damaged in both directions.

:class:`BytePtyProxy` is a pseudo-terminal the SDK opens as it opens an adapter; a thread copies bytes between
it and the :class:`~labkit.arm.bus.BusEmulator`'s pseudo-terminal, corrupting (XOR with a random non-zero
byte) and dropping each byte with the given probabilities, both ways. :func:`bus_fault_run` opens the arm
through it again and again and moves it, and counts:

- ``silent_goal_mismatches``: moves that returned normally while a servo's goal register (read below the
  proxy, in the emulator) differed from the host's goal for it: must be 0;
- ``opens`` / ``open_failures`` (each failure a :class:`~labkit.exceptions.BusFault` whose message says what was
  tried), ``moves`` / ``moves_ok`` / ``move_faults``, ``unexplained`` (a failure that is not a ``DeviceError``
  saying what was tried: must be 0), and ``longest_call_s`` (no hang: every open and move returns within
  a bound);
- with ``gripper=True`` (a robot file whose gripper is a bus servo) each arm move is followed by a gripper move
  to a random position with a random grip limit: ``gripper_moves`` / ``gripper_moves_ok`` / ``gripper_faults``,
  ``gripper_silent_mismatches`` (moves that returned normally while the gripper servo's goal or limit register
  differed from what was sent: must be 0), ``gripper_faults_naming_it`` (faults of a gripper write, naming
  ``servo N (gripper)``) and ``gripper_faults_unnamed`` (a fault during a gripper move that names neither the
  gripper servo nor the joint servo that failed, e.g. a joint's health read in a servo frame run meanwhile:
  must be 0).

The CI test runs a few moves; ``benchmarks/bench_bus_faults.py`` runs the same function longer and prints the
counts.
"""

from __future__ import annotations

import math
import os
import random
import re
import select
import threading
import time
import tty

import numpy as np
import pytest

from labkit.exceptions import DeviceError

#: what a message about a bus that lost status packets says it tried (the open-time ping, reads, writes)
TRIED = ("after", "tried at")


class BytePtyProxy:
    """A pseudo-terminal in front of ``target`` (another pseudo-terminal) that damages bytes both ways.

    Parameters
    ----------
    target : str
        The device to forward to (a :class:`BusEmulator`'s ``path``).
    corrupt, drop : float
        Probability of each byte being corrupted / dropped, in each direction.
    seed : int

    Attributes
    ----------
    path : str
        The pseudo-terminal to open instead of ``target``.
    counts : dict
        ``{"bytes", "corrupted", "dropped"}`` over both directions.
    """

    def __init__(self, target, *, corrupt=0.01, drop=0.005, seed=0):
        self.corrupt, self.drop = float(corrupt), float(drop)
        self._rng = random.Random(seed)
        self.counts = {"bytes": 0, "corrupted": 0, "dropped": 0}
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self._target = os.open(target, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self._target)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="byte fault proxy", daemon=True)
        self._thread.start()

    def _mangle(self, data):
        out = bytearray()
        for b in data:
            self.counts["bytes"] += 1
            r = self._rng.random()
            if r < self.drop:
                self.counts["dropped"] += 1
                continue
            if r < self.drop + self.corrupt:
                self.counts["corrupted"] += 1
                b ^= self._rng.randrange(1, 256)
            out.append(b)
        return bytes(out)

    def _run(self):
        ends = {self._master: self._target, self._target: self._master}
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select(list(ends), [], [], 0.01)
                for fd in ready:
                    data = self._mangle(os.read(fd, 4096))
                    if data:
                        os.write(ends[fd], data)
            except OSError:
                return

    def close(self):
        """Stop forwarding and close both ends (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(1.0)
        for fd in (self._master, self._slave, self._target):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _goal_mismatch(arm, emu):
    """Servos whose goal register differs from the host's last goal for them (the bus board's, read below the proxy)."""
    goal = arm.port.board._goal
    held = [emu.get(lk.bus.id, "goal_position") for lk in arm.robot.links]
    return [(lk.bus.id, g, h) for lk, g, h in zip(arm.robot.links, goal, held) if g != h]


def _gripper_mismatch(arm, emu, position, torque):
    """What the gripper servo holds (read below the proxy) that differs from a move to ``position`` with ``torque``."""
    from labkit.arm.bus import limit_register

    g = arm.robot.gripper
    field, value = limit_register(emu.bus, torque)
    want = {"goal_position": int(g.servo.ticks(position)), field: value}
    return {name: (v, emu.get(g.servo.id, name)) for name, v in want.items() if emu.get(g.servo.id, name) != v}


def bus_fault_run(robot_file, protocol, *, opens=3, moves_per_open=4, corrupt=0.01, drop=0.005, seed=0,
                  latency=20.0, step_deg=8.0, gripper=False):
    """Open ``robot_file``'s arm through a :class:`BytePtyProxy` ``opens`` times and move it; return the counts.

    Parameters
    ----------
    robot_file : str
    protocol : str
        ``"dynamixel"`` or ``"feetech"``.
    opens, moves_per_open : int
    corrupt, drop : float
        Byte fault probabilities (each direction).
    seed : int
    latency : float
        The URL's ``latency`` [ms] (status timeouts).
    step_deg : float
        Size of each move on every joint [deg].
    gripper : bool or "only"
        Follow each arm move with a move of the robot file's bus gripper (see the module notes); ``"only"``: move
        the gripper alone (``moves_per_open`` gripper moves, the joints hold).

    Returns
    -------
    dict
    """
    from labkit.arm import Arm
    from labkit.arm.bus import BusEmulator

    rng = np.random.default_rng(seed)
    counts = dict(opens=0, open_failures=0, moves=0, moves_ok=0, move_faults=0, silent_goal_mismatches=0,
                  unexplained=0, longest_call_s=0.0, bytes=0, corrupted=0, dropped=0, examples=[])
    if gripper:
        counts.update(gripper_moves=0, gripper_moves_ok=0, gripper_faults=0, gripper_silent_mismatches=0,
                      gripper_faults_naming_it=0, gripper_faults_unnamed=0, gripper_fault_examples=[])

    def timed(fn):
        t0 = time.monotonic()
        try:
            return fn()
        finally:
            counts["longest_call_s"] = max(counts["longest_call_s"], time.monotonic() - t0)

    def explained(exc):
        ok = isinstance(exc, DeviceError) and any(word in str(exc) for word in TRIED)
        if not ok:
            counts["unexplained"] += 1
        if len(counts["examples"]) < 3 or not ok:
            import traceback

            counts["examples"].append(f"{type(exc).__name__}: {str(exc)[:300]}" +
                                      ("" if ok else "".join(traceback.format_tb(exc.__traceback__)[-3:])))

    def gripper_move(arm, emu):
        """A gripper move to a random position and limit, counted; whether the arm may go on."""
        g = arm.robot.gripper
        position = float(rng.uniform(min(g.open, g.closed), max(g.open, g.closed)))
        torque = float(rng.uniform(0.2, 1.0) * (g.max_torque or emu.bus.MOTOR["stall_torque"]))
        counts["gripper_moves"] += 1
        try:
            timed(lambda: arm.move_gripper(position, max_torque=torque))
        except Exception as exc:  # noqa: BLE001 - counted and checked below
            counts["gripper_faults"] += 1
            explained(exc)
            if f"servo {g.servo.id} (gripper)" in str(exc):
                counts["gripper_faults_naming_it"] += 1
            elif not re.search(r"servo \d+ \(joint '", str(exc)):  # neither the gripper nor the joint that failed
                counts["gripper_faults_unnamed"] += 1
            if len(counts["gripper_fault_examples"]) < 3:
                counts["gripper_fault_examples"].append(f"{type(exc).__name__}: {str(exc)[:300]}")
            return False
        counts["gripper_moves_ok"] += 1
        mismatch = _gripper_mismatch(arm, emu, position, torque)
        if mismatch:
            counts["gripper_silent_mismatches"] += 1
            counts["examples"].append(f"gripper move returned while the servo holds {mismatch} (sent, held)")
        return True

    with BusEmulator(robot_file, wall_clock=True) as emu:
        for k in range(opens):
            with BytePtyProxy(emu.path, corrupt=corrupt, drop=drop, seed=seed * 1000 + k) as proxy:
                counts["opens"] += 1
                try:
                    arm = timed(lambda: Arm(robot_file, f"{protocol}://{proxy.path}?latency={latency:g}"))
                except Exception as exc:  # noqa: BLE001 - counted and checked below
                    counts["open_failures"] += 1
                    explained(exc)
                    arm = None
                if arm is not None:
                    try:
                        lo, hi = arm.robot.joint_limits.T
                        for _ in range(moves_per_open):
                            if gripper != "only":
                                counts["moves"] += 1
                                try:  # the commanded joints are read from the board (a bus read with a gripper)
                                    q = arm.commanded_joints()
                                    step = np.radians(step_deg) * rng.choice([-1.0, 1.0], size=q.shape)
                                    target = np.clip(q + step, lo + 0.1, hi - 0.1)
                                    timed(lambda: arm.move_joints(target, wait=True))
                                except Exception as exc:  # noqa: BLE001 - counted and checked below
                                    counts["move_faults"] += 1
                                    explained(exc)
                                    break
                                counts["moves_ok"] += 1
                                if _goal_mismatch(arm, emu):
                                    counts["silent_goal_mismatches"] += 1
                            if gripper and not gripper_move(arm, emu):
                                break
                    finally:
                        timed(arm.close)
                for key in ("bytes", "corrupted", "dropped"):
                    counts[key] += proxy.counts[key]
    return counts


def test_no_move_returns_while_a_servo_holds_another_goal(robot_file, kind):
    counts = bus_fault_run(robot_file, kind, opens=1, moves_per_open=3, corrupt=0.01, drop=0.005, seed=1, latency=10,
                           step_deg=3.0)
    assert counts["corrupted"] > 0 and counts["dropped"] > 0  # the proxy did damage bytes
    assert counts["silent_goal_mismatches"] == 0, counts
    assert counts["unexplained"] == 0, counts
    assert counts["longest_call_s"] < 30.0, counts  # no hang
    assert counts["moves"] + counts["open_failures"] >= 1


#: robot files whose gripper is a servo on the bus (the bundled OpenMANIPULATOR-X and SO-101)
GRIPPER_ROBOTS = {"dynamixel": "openmanipulator_x", "feetech": "so101"}


@pytest.mark.parametrize("kind", sorted(GRIPPER_ROBOTS))
def test_no_gripper_move_returns_while_its_servo_holds_another_goal_or_limit(kind):
    counts = bus_fault_run(GRIPPER_ROBOTS[kind], kind, opens=1, moves_per_open=4, corrupt=0.01, drop=0.005, seed=2,
                           latency=10, gripper="only")  # the gripper alone: an open is followed by a gripper move
    assert counts["corrupted"] > 0 and counts["dropped"] > 0
    assert counts["gripper_silent_mismatches"] == 0 and counts["silent_goal_mismatches"] == 0, counts
    assert counts["gripper_faults_unnamed"] == 0 and counts["unexplained"] == 0, counts
    assert counts["longest_call_s"] < 30.0, counts
    assert counts["gripper_moves"] + counts["open_failures"] >= 1, counts


def test_the_proxy_damages_bytes_at_the_rates_asked():
    from labkit.arm.bus import BusEmulator
    from tests.arm.bus.conftest import ROBOTS

    with BusEmulator(ROBOTS["dynamixel"]) as emu, BytePtyProxy(emu.path, corrupt=0.2, drop=0.1, seed=3) as proxy:
        damaged = proxy._mangle(bytes(range(256)) * 40)
        assert math.isclose(proxy.counts["dropped"] / proxy.counts["bytes"], 0.1, abs_tol=0.02)
        assert math.isclose(proxy.counts["corrupted"] / proxy.counts["bytes"], 0.2, abs_tol=0.02)
        assert len(damaged) == proxy.counts["bytes"] - proxy.counts["dropped"]
