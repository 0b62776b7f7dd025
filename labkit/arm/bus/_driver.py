"""The host side of a servo bus: one driver per vendor SDK behind one interface (:class:`BusDriver`).

A driver opens the bus device with the vendor's ``PortHandler`` at the robot file's baud rate,
pings every servo, sets torque and motion profiles, writes every joint's goal position in one
sync-write packet and reads every joint's present position and current in one sync read. Every
failure is a :class:`BusFault` naming the servo, its joint, what was tried and what to check. Nothing is
taken on trust (:mod:`labkit.arm.bus._confirm`): a ping, a read and a register write whose status packet
is lost are tried again a bounded number of times, and every goal-position and torque write (a sync write,
which has no status packet) is read back and sent again until each servo holds its value.
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import BusFault, BusWarning, DeviceError
from labkit.robot import BusGripper
from labkit.arm.bus._adapter import advice, latency_note, latency_timer, paced_by, served_by
from labkit.arm.bus._confirm import READ_TRIES, read_registers, write_confirmed, write_unconfirmed

__all__ = ["BusFault", "BusReading"]


#: sync writes of a best-effort torque off (after a fault, on close), each read back once
QUIET_TRIES = 3


def _with_latency(port_class, latency):
    """The SDK's ``PortHandler`` with its status-packet timeout computed for an adapter latency of ``latency`` ms."""

    class Port(port_class):
        def setPacketTimeout(self, packet_length):  # the SDK's formula, with this bus's latency
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = self.tx_time_per_byte * packet_length + latency * 2.0 + 2.0

    return Port


def _sdk_latency(port_class):
    """The adapter latency [ms] the SDK's ``PortHandler`` assumes (its module's ``LATENCY_TIMER``)."""
    for cls in port_class.__mro__:
        value = getattr(sys.modules.get(cls.__module__), "LATENCY_TIMER", None)
        if value is not None:
            return value
    return 16.0


@dataclass(frozen=True)
class BusReading:
    """One sync read of every joint's servo.

    Attributes
    ----------
    t : float
        Board time of the read [s].
    ticks : ndarray of int, shape (n,)
        Present positions [ticks].
    q : ndarray, shape (n,)
        Present joint values [rad] (through each joint's ``bus`` zero and direction).
    current : ndarray, shape (n,)
        Present current of each servo [A], the load signal hobby servos lack (signed).
    """

    t: float
    ticks: np.ndarray
    q: np.ndarray
    current: np.ndarray


class BusDriver:
    """A servo bus through a vendor SDK (subclasses: one per bus protocol, the ``Driver`` of its codec module).

    Parameters
    ----------
    robot : labkit.robot.Robot
        A robot with a ``[bus]`` table: baud rate, resolution, each joint's servo id.
    device : str
        Serial device of the bus adapter (``/dev/ttyUSB0``, a pseudo-terminal of the virtual bus).
    retries : int
        Extra attempts of a ping, a read or a write whose status packets were lost or corrupt (a state read
        asks again only the servos without an intact one).
    name : str, optional
        How messages name the bus (default ``"<protocol>://<device>"``).
    latency : float, optional
        The adapter's latency [ms] in the SDK's status-packet timeout (``2 * latency + 2 ms`` plus the packet's
        wire time); default the robot file's ``[bus] latency``, else the SDK's 16 ms (an FTDI adapter's default
        latency timer). On a virtual bus of this process (:class:`BusEmulator`) the timeout starts once the
        emulator has the request: a loaded host delays its thread, not a servo.
        An adapter whose USB latency timer (read from sysfs on Linux) is above it gives a :class:`BusWarning`
        with the one-line fix, and every message about lost status packets repeats it.

    Raises
    ------
    DeviceError
        The device cannot be opened or set to the baud rate.
    """

    protocol = ""
    table = {}
    state = (0, 0)
    current_unit = 1.0
    errors = {}
    profile = ()

    def __init__(self, robot, device, *, retries=READ_TRIES - 1, name=None, latency=None):
        self.device = device
        self.robot = robot
        self.resolution = robot.bus.resolution
        self.baudrate = robot.bus.baudrate
        self.ids = [lk.bus.id for lk in robot.links]
        self.retries = int(retries)
        #: sync-write packets sent (a virtual bus waits until it has handled as many)
        self.sync_writes = 0
        self.name = name or f"{self.protocol}://{device}"
        self.sdk, port_class, self.packets = self._sdk()
        if latency is None:
            latency = getattr(robot.bus, "latency", None)
        if latency is not None:
            port_class = _with_latency(port_class, float(latency))
        emulator = served_by(device)
        if emulator is not None:  # a virtual bus of this process: timeouts from when it has the request
            port_class = paced_by(port_class, emulator)
        #: the adapter latency the status timeouts allow for [ms]; the adapter's USB latency timer [ms] or None
        self.latency = float(latency) if latency is not None else float(_sdk_latency(port_class))
        self.latency_timer = latency_timer(device)
        self.handler = port_class(device)
        #: the port has been closed (:meth:`close`)
        self.closed = False
        try:
            ok = self.handler.openPort()
        except Exception as exc:  # noqa: BLE001 - pyserial's SerialException or an OSError
            raise DeviceError(f"cannot open the {self.protocol} bus {device!r}: {exc}; is the adapter (U2D2, "
                              f"OpenRB-150, Feetech board) plugged in? 'labkit ports' lists the serial ports") from None
        if not ok or not self.handler.setBaudRate(self.baudrate):
            self.handler.closePort()
            raise DeviceError(f"cannot set the {self.protocol} bus {device!r} to {self.baudrate} bit/s")
        # the SDKs open the port with timeout=0 and poll it while a status packet is due: a 1 ms read timeout
        # lets that wait sleep in select() instead of spinning (a read still returns as soon as its bytes came)
        self.handler.ser.timeout = 0.001
        note = latency_note(device, self.latency_timer, self.latency)
        if note:
            warnings.warn(f"{self.name}: {note}", BusWarning, stacklevel=3)

    # what each subclass defines: _sdk() -> (sdk module, PortHandler, PacketHandler); _sync_read_tx(address, size,
    # ids) -> result; _hardware_error(servo_id, error) -> text; _decode_state(data) -> (position [ticks], current
    # [LSB]); _velocity_value(rad/s), _acceleration_value(rad/s^2) -> the profile registers' values

    # -- messages ------------------------------------------------------------------------------
    def servo(self, servo_id):
        """``"servo 12 (joint 'shoulder')"`` (``"servo 15 (gripper)"`` for a bus gripper) for messages.

        Parameters
        ----------
        servo_id : int

        Returns
        -------
        str
        """
        names = dict(zip(self.ids, self.robot.joint_names))
        if servo_id not in names and isinstance(self.robot.gripper, BusGripper) and self.robot.gripper.servo.id == servo_id:
            return f"servo {servo_id} (gripper)"
        return f"servo {servo_id} (joint {names.get(servo_id, '?')!r})"

    def describe(self, code):
        """The names of the hardware-error bits set in ``code`` (``"hardware error 0x20 (overload)"``).

        Parameters
        ----------
        code : int
            Hardware error status (Dynamixel address 70) or status-packet error byte (Feetech).

        Returns
        -------
        str
        """
        names = [name for bit, name in self.errors.items() if code & bit]
        return f"hardware error {code:#04x} ({', '.join(names) or 'unknown bits'})"

    def _comm(self, result):
        return self.packets.getTxRxResult(result).replace("[TxRxResult] ", "")

    # -- requests ---------------------------------------------------------------------------------
    def ping_all(self):
        """Ping every joint's servo; raise a :class:`BusFault` naming the first that does not answer.

        Returns
        -------
        dict of int to int
            Servo id -> model number.
        """
        return {servo_id: self.ping(servo_id) for servo_id in self.ids}

    def ping(self, servo_id):
        """Ping one servo, again up to ``retries`` times while its status packet is lost or damaged.

        Parameters
        ----------
        servo_id : int

        Returns
        -------
        int
            Its model number.

        Raises
        ------
        BusFault
            No intact answer after the retries (the message says what came back, what was tried and what to check).
        """
        replies = []
        for _ in range(self.retries + 1):
            self.handler.clearPort()
            try:
                model, result, error = self.packets.ping(self.handler, servo_id)
            except IndexError:  # feetech-servo-sdk takes the model number from a short packet unchecked
                result = self.sdk.COMM_RX_CORRUPT
            if result == self.sdk.COMM_SUCCESS:
                return model
            replies.append(self._comm(result))
        damaged = [r for r in replies if r != self._comm(self.sdk.COMM_RX_TIMEOUT)]
        what = (f"answers only with damaged status packets ({damaged[-1]})" if len(damaged) == len(replies)
                else f"does not answer ping ({', '.join(dict.fromkeys(replies))})")
        raise BusFault(f"{self.name}: {self.servo(servo_id)} {what} after {len(replies)} pings; check its "
                       f"id; {advice(self)}")

    def write(self, servo_id, field, value, *, check_error=True):
        """Write ``value`` to control-table ``field`` of one servo and check its status packet.

        Parameters
        ----------
        servo_id : int
        field : str
            A key of the driver's control table (``"torque_enable"`` ...).
        value : int
        check_error : bool
            Raise when the status packet flags a hardware error (a servo in error still runs the write:
            turning its torque off passes ``False``).
        """
        address, size = self.table[field]
        fn = {1: self.packets.write1ByteTxRx, 2: self.packets.write2ByteTxRx, 4: self.packets.write4ByteTxRx}[size]
        for _ in range(self.retries + 1):  # writing a register twice is harmless: retried when its status is lost
            result, error = fn(self.handler, servo_id, address, int(value) & ((1 << 8 * size) - 1))
            if result == self.sdk.COMM_SUCCESS:
                break
        if result != self.sdk.COMM_SUCCESS:
            raise BusFault(f"{self.name}: writing {field} of {self.servo(servo_id)} failed after {self.retries + 1} "
                           f"writes: {self._comm(result)}; {advice(self)}")
        if error and check_error:
            raise BusFault(f"{self.name}: {self.servo(servo_id)} reports {self._hardware_error(servo_id, error)}")

    def torque(self, on):
        """Torque on (or off) on every joint's servo.

        Parameters
        ----------
        on : bool
        """
        write_confirmed(self, "torque_enable", {i: 1 if on else 0 for i in self.ids})

    def torque_off_quietly(self):
        """Try to turn every servo's torque off; never raises (after a fault, on close).

        Returns
        -------
        list of int
            Ids whose torque-off was not acknowledged.
        """
        try:
            # a few tries only: after a fault the bus may be dead, and the caller says what was not acknowledged
            return sorted(write_unconfirmed(self, "torque_enable", {i: 0 for i in self.ids}, tries=QUIET_TRIES,
                                            read_tries=1, check_error=False))
        except Exception:  # noqa: BLE001 - best effort: the bus may be what failed
            return list(self.ids)

    def set_profiles(self):
        """Each servo's speed and acceleration profile from the robot file's ``max_velocity`` / ``max_acceleration``.

        A joint without a limit keeps the servo's setting.
        """
        velocity, acceleration = self.profile
        for lk in self.robot.links:
            if lk.max_velocity is not None:
                self.write(lk.bus.id, velocity, self._velocity_value(lk.max_velocity))
            if lk.max_acceleration is not None:
                self.write(lk.bus.id, acceleration, self._acceleration_value(lk.max_acceleration))

    def write_goals(self, ticks):
        """Every joint's goal position in one sync-write packet, read back and sent again until every servo holds it.

        Parameters
        ----------
        ticks : sequence of int, shape (n,)
            Goal positions [ticks].

        Raises
        ------
        BusFault
            A servo that does not hold its goal after the bounded writes and read-backs (named, with what it
            holds).
        """
        write_confirmed(self, "goal_position", dict(zip(self.ids, (int(t) for t in ticks))))

    def read_state(self, t=0.0):
        """Every joint's present position and current in one sync read.

        Parameters
        ----------
        t : float
            Board time to stamp the reading with [s].

        Returns
        -------
        BusReading

        Raises
        ------
        BusFault
            No intact status packet from a servo after ``retries`` extra attempts, or a servo reports a
            hardware error (overload, overheating ...).
        """
        address, size = self.state
        data = read_registers(self, address, size, self.ids, tries=self.retries + 1)
        rows = [self._decode_state(data[servo_id]) for servo_id in self.ids]
        ticks = np.array([r[0] for r in rows], dtype=np.int64)
        q = np.array([float(lk.bus.joint(k)) for lk, k in zip(self.robot.links, ticks)])
        return BusReading(float(t), ticks, q, np.array([r[1] for r in rows], float) * self.current_unit)

    def close(self):
        """Turn every servo's torque off (best effort) and close the port; never raises (idempotent)."""
        if self.closed:
            return
        self.closed = True
        try:
            self.torque_off_quietly()
        finally:
            try:
                self.handler.closePort()
            except Exception:  # noqa: BLE001 - a vanished adapter
                pass
