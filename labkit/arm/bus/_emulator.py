"""Virtual servo buses: a Dynamixel Protocol 2.0 or Feetech STS bus on a pseudo-terminal.

:class:`BusEmulator` serves one bus on a new pseudo-terminal, so that a vendor SDK opens it
as it opens a USB adapter. It parses every packet with the bus module's codec (header, CRC-16
or checksum, byte stuffing, lengths; a damaged packet is counted in :attr:`BusEmulator.rejected`
and never answered; an unfinished packet is dropped after :data:`PACKET_TIMEOUT` without a byte), runs ping, read, write, sync read and sync write on each servo's control
table, answers status packets, and moves the servos with the virtual arm's physics
(:class:`labkit.arm.ArmModel`: the goal positions are the model's commands, the present positions
its shaft angles, the present current its gravity torque over the servo's torque constant).

Faults are set on :attr:`BusEmulator.faults` while it runs: status packets dropped or corrupted,
a servo silent, a servo in overload (hardware error, torque off, as a real servo protects itself).

A driver of this process on :attr:`BusEmulator.path` starts each status timeout once the emulator has
answered what it sent (:attr:`BusEmulator.handled`, :func:`labkit.arm.bus._adapter.paced_by`): a loaded host
delays the emulator's thread, not a servo's answer.

The physics runs on the clock of whoever drives it: :class:`BusBoard` advances the model to its
board time before each bus transaction (so ``sim://...?bus=dynamixel&clock=lockstep`` stays
deterministic); with ``wall_clock=True`` the emulator advances it to the wall clock itself.
"""

from __future__ import annotations

import os
import select
import threading
import time
from dataclasses import dataclass, field, replace

import numpy as np

from labkit.exceptions import OptionError
from labkit.robot import BusGripper, Robot
from labkit.arm.board import ArmModel, PhysicsConfig, gravity_sag
from labkit.arm.bus._adapter import serve
from labkit.arm.bus._registry import bus_module
from labkit.arm.bus._servo_loop import PositionLoops
from labkit.arm.bus._gripper import VirtualGripper, limit_torque
from labkit.arm.bus._hardware import VirtualHand, VirtualServo, assembled_servos, goal_joint, present_ticks

__all__ = ["BusEmulator", "BusFaults"]

#: a servo's receive timeout [s]: bytes of an unfinished packet are dropped after this long without a byte (a
#: damaged length field would otherwise make it wait for bytes that belong to the next packets)
PACKET_TIMEOUT = 0.02


@dataclass
class BusFaults:
    """Faults a :class:`BusEmulator` injects (mutable while it runs).

    Attributes
    ----------
    drop_status : int
        The next this many status packets are not sent (a lost packet).
    corrupt_status : int
        The next this many status packets are sent with a wrong CRC / checksum.
    silent : set of int
        Servo ids that answer nothing.
    overload : set of int
        Servo ids in overload: hardware error status set, torque off, every status packet flags it.
    """

    drop_status: int = 0
    corrupt_status: int = 0
    silent: set = field(default_factory=set)
    overload: set = field(default_factory=set)


class BusEmulator:
    """A virtual servo bus of ``robot`` (its ``[bus]`` table) on a pseudo-terminal.

    Parameters
    ----------
    robot : Robot or str
        A robot file with a ``[bus]`` table; every joint's ``bus`` id is one virtual servo.
    config : PhysicsConfig
        The virtual arm's physics (default: no deadband, a smart servo has none to speak of).
    q0 : array_like, shape (n,), optional
        Where the arm rests at power-up [rad] (default: the middle of the joint limits).
    wall_clock : bool
        Advance the physics to the wall clock before each packet (for a bus served alone);
        ``False``: whoever drives the bus advances :attr:`model`.
    servo_load : bool
        Whether the servos' position loops carry the gravity load (a servo then droops under load as a real
        one with no integral gain does); default ``False``: the loops drive the inertia alone and the load
        shows only in the present current (see :class:`PositionLoops`).
    servos : sequence of VirtualServo, optional
        How each servo is really mounted (raw zero, direction, stops; :func:`assembled_servos`); default
        the robot file's ``zero`` and ``direction`` (a calibrated arm).

    Attributes
    ----------
    path : str
        The pseudo-terminal to open (``/dev/pts/N``).
    model : ArmModel
        The virtual arm (true joints, ruler).
    memory : dict of int to bytearray
        Each servo's control table.
    packets : list of tuple
        Every intact instruction packet ``(instruction name, id, params)``, oldest first.
    rejected : list of str
        Why each damaged packet was dropped.
    faults : BusFaults
    hardware : tuple of VirtualServo
        The servos as mounted.
    hand : VirtualHand
        Moves a joint whose torque is off (a guided calibration's student).

    Examples
    --------
    >>> emu = BusEmulator("tests/arm/bus/omx_test.toml")   # doctest: +SKIP
    >>> emu.path                                           # doctest: +SKIP
    '/dev/pts/5'
    """

    def __init__(self, robot, config=PhysicsConfig(deadband=0.0), *, q0=None, wall_clock=False, servo_load=False,
                 servos=None):
        self.robot = Robot.load(robot)
        if self.robot.bus is None:
            raise OptionError(f"expected a robot file with a [bus] table for a virtual bus, got {self.robot.name!r} "
                              f"(hobby servos: use sim://{self.robot.name})")
        self.bus = bus_module(self.robot.bus.protocol)
        limits = self.robot.joint_limits
        q0 = limits.mean(axis=1) if q0 is None else np.asarray(q0, float)
        self.model = ArmModel(self.robot, config, q0=q0)
        #: each servo's position loop on the dynamics (the model's servos; see labkit.arm.bus._servo_loop)
        self.model.servos = PositionLoops(self.robot, config, self.bus, self.model.servos.position,
                                          gravity=servo_load)
        self._unit_load = replace(config, joint_compliance=1.0)
        self.ids = [lk.bus.id for lk in self.robot.links]
        self.hardware = assembled_servos(self.robot) if servos is None else tuple(servos)
        if len(self.hardware) != self.robot.n or not all(isinstance(s, VirtualServo) for s in self.hardware):
            raise OptionError(f"expected servos as {self.robot.n} VirtualServo, got {servos!r}")
        self.hand = VirtualHand(self)
        self.memory = {i: bytearray(256) for i in self.ids}
        self.faults = BusFaults()
        self.packets = []
        self.rejected = []
        self.status_sent = 0
        #: sync-write packets handled (a sync write has no status packet: :meth:`wait_sync_writes` waits for them)
        self.sync_writes = 0
        self.wall_clock = bool(wall_clock)
        self._t0 = time.monotonic()
        self._fresh = None
        for j, servo_id in enumerate(self.ids):
            self._put(servo_id, "model_number", self.bus.MODEL)
            self._put(servo_id, "id", servo_id)
            self._put(servo_id, "goal_position", present_ticks(self, j, q0[j]))
            for name, value in self.bus.DEFAULT_GAINS.items():
                self._put(servo_id, self.bus.GAINS[name][0], value)
        #: the gripper servo (a :class:`VirtualGripper`, its ``object`` settable) if the robot file has a bus gripper
        self.gripper = None
        if isinstance(self.robot.gripper, BusGripper):
            g = self.robot.gripper
            self.gripper = VirtualGripper(self.bus, g, 0.5 * (g.open + g.closed))
            self.memory[g.servo.id] = bytearray(256)
            self._put(g.servo.id, "model_number", self.bus.MODEL)
            self._put(g.servo.id, "id", g.servo.id)
            self._put(g.servo.id, "goal_position", int(g.servo.ticks(self.gripper.position)))
            limits = {"operating_mode": 3, "current_limit": self.bus.CURRENT_LIMIT, "goal_current": self.bus.CURRENT_LIMIT,
                      "torque_limit": self.bus.MOTOR["full_scale"]}
            for name, value in limits.items():
                if name in self.bus.TABLE and value is not None:
                    self._put(g.servo.id, name, value)
        self._refresh()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._master, self._slave = os.openpty()
        import tty

        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        #: bytes read from the host and answered (a driver of this process starts its status timeouts from here)
        self.handled = 0
        self._thread = threading.Thread(target=self._serve, name=f"labkit {self.bus.PROTOCOL} bus", daemon=True)
        self._thread.start()
        serve(self.path, self)

    # -- control tables ---------------------------------------------------------------------------
    def _put(self, servo_id, name, value):
        address, size = self.bus.TABLE[name]
        if self.bus.SIGN_MAGNITUDE and value < 0:
            value = -value | 1 << (8 * size - 1)
        self.memory[servo_id][address:address + size] = int(value).to_bytes(size, "little", signed=value < 0)

    def get(self, servo_id, name):
        """The value of control-table field ``name`` of servo ``servo_id`` (unsigned).

        Parameters
        ----------
        servo_id : int
        name : str
            A key of the bus module's ``TABLE``.

        Returns
        -------
        int
        """
        address, size = self.bus.TABLE[name]
        return int.from_bytes(self.memory[servo_id][address:address + size], "little")

    def torque(self, servo_id):
        """Whether servo ``servo_id``'s torque is on.

        Parameters
        ----------
        servo_id : int

        Returns
        -------
        bool
        """
        return bool(self.get(servo_id, "torque_enable"))

    def _refresh(self):
        """Present position and current of every servo from the physics, now."""
        if self.wall_clock:
            self.model.advance_to(time.monotonic() - self._t0)
        q = self.model.shaft_q
        torques = tuple(self.torque(i) for i in self.ids)
        self._refresh_gripper()
        key = (self.model.time, tuple(q), torques, frozenset(self.faults.overload))
        if key == self._fresh:
            return
        self._fresh = key
        hold = -gravity_sag(self.robot, q, self._unit_load)  # the torque each servo gives to hold the arm [N m]
        for j, (lk, servo_id) in enumerate(zip(self.robot.links, self.ids)):
            self._put(servo_id, "present_position", present_ticks(self, j, q[j]))
            kt = lk.bus.torque_constant or self.bus.TORQUE_CONSTANT  # the robot file's datasheet value first
            amps = hold[j] / kt * self.hardware[j].direction if self.torque(servo_id) else 0.0
            self._put(servo_id, "present_current", int(round(amps / self.bus.CURRENT_UNIT)))
            if servo_id in self.faults.overload:
                self._overload(servo_id)

    def _sync_loop(self, servo_id):
        """The servo's torque and position-loop gains from its control table into its loop."""
        j = self.ids.index(servo_id)
        loops = self.model.servos
        loops.enable(j, self.torque(servo_id))
        loops.set_gains(j, {name: self.get(servo_id, field) for name, (field, _, _) in self.bus.GAINS.items()})

    def _refresh_gripper(self):
        """The gripper servo's jaw run to the model's time, its present position and current in its table."""
        if self.gripper is None:
            return
        g = self.robot.gripper
        sid = g.servo.id
        address, size = self.bus.TABLE["goal_position"]
        goal = float(g.servo.joint(int.from_bytes(self.memory[sid][address:address + size], "little", signed=True)))
        limit = limit_torque(self.bus, lambda field: self.get(sid, field))
        self.gripper.advance_to(self.model.time, goal, self.torque(sid), limit)
        self._put(sid, "present_position", int(g.servo.ticks(self.gripper.position)))
        self._put(sid, "present_current", int(round(self.gripper.current / self.bus.CURRENT_UNIT)))

    def _overload(self, servo_id):
        self.memory[servo_id][self.bus.TABLE["torque_enable"][0]] = 0
        self.model.servos.enable(self.ids.index(servo_id), False)
        if "hardware_error" in self.bus.TABLE:
            self._put(servo_id, "hardware_error", 0x20)

    def _error_byte(self, servo_id):
        if servo_id not in self.faults.overload:
            return 0
        return self.bus.ALERT if self.bus.ALERT is not None else 0x20

    def _apply_write(self, servo_id, address, data):
        mem = self.memory[servo_id]
        mem[address:address + len(data)] = bytes(data)
        self._fresh = None  # a homing offset changes what the servo reports
        if servo_id not in self.ids:  # the gripper servo: its jaw reads its table (_refresh_gripper)
            return
        goal, size = self.bus.TABLE["goal_position"]
        torque = self.bus.TABLE["torque_enable"][0]
        if address <= torque < address + len(data) and servo_id in self.faults.overload and mem[torque]:
            mem[torque] = 0  # a servo in overload keeps its torque off until rebooted
        self._sync_loop(servo_id)
        if self.torque(servo_id) and address < goal + size and goal < address + len(data):
            j = self.ids.index(servo_id)
            ticks = int.from_bytes(mem[goal:goal + size], "little", signed=True)
            q = self.model.servos.commanded
            q[j] = goal_joint(self, j, ticks)
            self.model.command(q)

    # -- packets ------------------------------------------------------------------------------------
    def _serve(self):
        buf, last = b"", time.monotonic()
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.01)
                if not ready:
                    if buf and time.monotonic() - last > PACKET_TIMEOUT:  # a servo drops a packet that stalls
                        with self._lock:
                            self.rejected.append(f"{len(buf)} bytes of an incomplete packet")
                        buf = b""
                    continue
                data = os.read(self._master, 4096)
                last = time.monotonic()
            except OSError:
                return
            packets, buf, rejected = self.bus.decode(buf + data)
            with self._lock:
                self.rejected += rejected
                for servo_id, instruction, params in packets:
                    out = self.handle(servo_id, instruction, params)
                    if out:
                        try:
                            os.write(self._master, out)
                        except OSError:
                            return
                self.handled += len(data)

    def handle(self, servo_id, instruction, params):
        """Run one intact instruction packet; return the bytes of the status packets that answer it.

        Parameters
        ----------
        servo_id : int
            The packet's id (``0xFE``: broadcast).
        instruction : int
        params : list of int
            Unstuffed parameter bytes.

        Returns
        -------
        bytes
        """
        bus = self.bus
        name = bus.INSTRUCTIONS.get(instruction)
        self.packets.append((name or f"{instruction:#04x}", servo_id, list(params)))
        if name is None:
            self.rejected.append(f"unknown instruction {instruction:#04x}")
            return b""
        a = bus.ADDRESS_BYTES
        if name in ("read", "sync read"):
            self._refresh()

        def number(chunk):
            return int.from_bytes(bytes(chunk), "little")

        replies = []
        if name == "ping":
            targets = self.ids if servo_id == bus.BROADCAST else [servo_id]
            replies = [(i, bus.ping_reply(bus.MODEL)) for i in targets if i in self.memory]
        elif name == "read" and servo_id in self.memory:
            address, size = number(params[:a]), number(params[a:2 * a])
            replies = [(servo_id, list(self.memory[servo_id][address:address + size]))]
        elif name == "write" and servo_id in self.memory:
            self._apply_write(servo_id, number(params[:a]), params[a:])
            replies = [(servo_id, [])]
        elif name == "sync read" and servo_id == bus.BROADCAST:
            address, size = number(params[:a]), number(params[a:2 * a])
            replies = [(i, list(self.memory[i][address:address + size])) for i in params[2 * a:] if i in self.memory]
        elif name == "sync write" and servo_id == bus.BROADCAST:
            address, size = number(params[:a]), number(params[a:2 * a])
            rows = params[2 * a:]
            if size <= 0 or len(rows) % (size + 1):
                self.rejected.append(f"sync write of {len(rows)} bytes in rows of {size + 1}")
                return b""
            for k in range(0, len(rows), size + 1):
                if rows[k] in self.memory:
                    self._apply_write(rows[k], address, rows[k + 1:k + 1 + size])
            self.sync_writes += 1
        return b"".join(self._status(i, p) for i, p in replies)

    def _status(self, servo_id, params):
        if servo_id in self.faults.silent:
            return b""
        if self.faults.drop_status > 0:
            self.faults.drop_status -= 1
            return b""
        out = bytearray(self.bus.status(servo_id, self._error_byte(servo_id), params))
        if self.faults.corrupt_status > 0:
            self.faults.corrupt_status -= 1
            out[-1] ^= 0x5A
        self.status_sent += 1
        return bytes(out)

    def wait_sync_writes(self, count, timeout=2.0):
        """Wait until ``count`` sync-write packets have been handled (they have no status packet to wait for).

        Parameters
        ----------
        count : int
            Sync writes sent so far by the host.
        timeout : float
            Longest wait [s of wall time].

        Returns
        -------
        bool
            Whether they all arrived.
        """
        deadline = time.monotonic() + timeout
        while self.sync_writes < count:
            if time.monotonic() > deadline:
                return False
            time.sleep(0.0002)
        return True

    # -- life -----------------------------------------------------------------------------------------
    @property
    def serving(self):
        """Whether the bus still reads and answers packets (not closed, its thread alive)."""
        return not self._stop.is_set() and self._thread.is_alive()

    def close(self):
        """Stop serving and close the pseudo-terminal (idempotent)."""
        if self._master != -1:
            serve(self.path, None)
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(1.0)
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self._master = self._slave = -1

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
