"""A host-side board for a servo bus: labkit's protocol to :class:`~labkit.arm.Arm`, the vendor SDK to the servos.

:class:`BusBoard` holds the board's firmware, an :class:`labkit.arm.board.Executor` (the same
request parser, checks, segment queue and executor every in-process board holds), and is its
servos: the ``MOVE`` s and ``SEG`` s :class:`~labkit.arm.Arm` sends are checked and run exactly as on
every other board, and each 20 ms servo frame writes the executor's joint values as goal positions
to every servo in one sync-write packet, read back and sent again until every servo holds its goal (a
move never returns while a servo's goal differs from the host's). Every fifth frame, every ``READ`` and every stream frame
read the servos' present positions and currents in one sync read.

The servos' range replaces the hobby-servo window: a joint may go anywhere within its limits
(the robot-file loader checks that the limits map inside the servo's ticks). The board starts
where the arm is: it reads the present positions until two sync reads in a row agree (a damaged status
packet that passes Feetech's 8-bit checksum by chance must not become a goal), refuses an arm resting
outside its limits (torque stays off), makes them the goals, sets the motion profiles and turns torque on.

A bus failure (a servo silent, a corrupt status packet after the retries, a hardware error such
as an overload) stops the executor, turns torque off on every servo and raises a
:class:`BusFault` (a :class:`~labkit.exceptions.DeviceError`), again on every later use until the
port is closed. Closing turns torque off.
"""

from __future__ import annotations

import atexit
import math
import weakref

from labkit.exceptions import DeviceError, OptionError
from labkit.robot import BusGripper, Robot
from labkit.arm.board import Executor
from labkit.arm.bus._adapter import advice
from labkit.arm.bus._confirm import READ_TRIES
from labkit.arm.bus._driver import BusFault
from labkit.arm.bus._gains import GainBook
from labkit.arm.bus._gripper import GripperServo
from labkit.arm.bus._registry import bus_module

__all__ = ["BusBoard", "open_bus_board"]

#: a health read (present position, current, errors) every this many servo frames while nothing else reads
HEALTH_FRAMES = 5
#: at power-up two sync reads in a row must agree within this fraction of a turn (1 deg) on every joint
AGREE_TURN = 1 / 360


class _Unpowered:
    """The physics slot on a real bus: the servos are real, nothing to simulate."""

    def advance_to(self, t):
        pass


class BusBoard:
    """labkit's board protocol in front of a servo bus (see the module notes).

    Parameters
    ----------
    robot : Robot or str
        A robot with a ``[bus]`` table.
    driver : BusDriver
        The open bus (:class:`DynamixelDriver`, :class:`FeetechDriver`).
    model : ArmModel, optional
        The virtual arm behind a virtual bus (:class:`BusEmulator`): advanced to board time before
        each bus transaction; ``None`` on a real bus.
    queue : int
        Segment queue depth.

    Attributes
    ----------
    executor : Executor
        The board's firmware: its state (``q``, ``segments``, ``done`` ...), commands and clock.
    reading : BusReading or None
        The last sync read.
    stream_rows : list of tuple
        ``(counter, t_ms, ticks..., current...)`` of the stream frames since ``STREAM`` was switched on.
    fault : BusFault or None
        The failure that stopped the board.
    goals_sent : int
        Sync-write packets of goal positions sent.

    Raises
    ------
    BusFault
        A servo does not answer, or the arm rests outside its joint limits (torque stays off).
    """

    #: ``GRIP`` (a pulse width) is refused (``ERR 5 RANGE``), never a silent no-op: a bus gripper is a servo on the
    #: bus, moved through the port (:meth:`move_gripper`)
    grip_refused = "GRIP takes a pulse width: a servo-bus gripper moves with Arm.open_gripper / move_gripper"

    def __init__(self, robot, driver, *, model=None, queue=6):
        robot = Robot.load(robot)
        if robot.bus is None:
            raise OptionError(f"expected a robot file with a [bus] table, got {robot.name!r}")
        self.robot = robot
        self.driver = driver
        self.fault = None
        self.reading = None
        self.stream_rows = []
        self.goals_sent = 0
        self._model = model
        self._physics = model if model is not None else _Unpowered()
        self._lim = [(round(math.degrees(lo) * 100), round(math.degrees(hi) * 100)) for lo, hi in robot.joint_limits]
        self._goal = None
        self._frames = 0
        #: the servos' position-loop gains (read, written within range, restored on close)
        self.gains = GainBook(driver)
        #: the gripper servo (robot file's [gripper] with bus = {...}), else None
        self.gripper = GripperServo(driver, robot.gripper) if isinstance(robot.gripper, BusGripper) else None
        self.executor = Executor(self, robot.n, queue=queue)
        self.executor.boot("POWER")
        atexit.register(_shutdown_at_exit, weakref.ref(self))  # torque off if the program ends with the arm open

    # -- what a port drives (labkit.arm.urlhandler) ---------------------------------------------------
    @property
    def time(self):
        """Board time [s] since power-up."""
        return self.executor.time

    @property
    def out_waiting(self):
        """Number of bytes sent by the board and not yet taken."""
        return self.executor.out_waiting

    def take_output(self, size=None):
        """Remove and return up to ``size`` bytes the board has sent (all if ``None``).

        Parameters
        ----------
        size : int, optional

        Returns
        -------
        bytes
        """
        return self.executor.take_output(size)

    def next_event_time(self):
        """Board time [s] of the next servo frame or stream frame.

        Returns
        -------
        float
        """
        return self.executor.next_event_time()

    def receive(self, data):
        """Bytes from the host (refused once the bus has failed, see :meth:`Executor.receive`).

        Parameters
        ----------
        data : bytes-like
        """
        if self.fault is not None:
            raise BusFault(str(self.fault))
        self.executor.receive(data)

    def advance_to(self, t):
        """Run the board until board time ``t`` [s] (servo frames go to the bus).

        Parameters
        ----------
        t : float
        """
        if self.fault is not None:
            raise BusFault(str(self.fault))
        self.executor.advance_to(t)

    def advance(self, dt):
        """Run the board for ``dt`` seconds of board time.

        Parameters
        ----------
        dt : float
        """
        self.advance_to(self.executor.time + dt)

    def reset(self, reason="EXTERNAL"):
        """Reset the board: RAM state lost, the servos read again where they are, ``READY`` 0.1 s later.

        Parameters
        ----------
        reason : str
        """
        self.executor.boot(reason)

    @property
    def virtual_model(self):
        """The virtual arm behind a virtual bus (:class:`labkit.arm.ArmModel`), ``None`` on a real bus."""
        return self._model

    def read_servos(self):
        """A sync read of every servo now (board time), checked for faults.

        Returns
        -------
        BusReading

        Raises
        ------
        BusFault
        """
        return self._guard(self._read)

    def servo_stream(self):
        """The stream frames read since ``STREAM`` was switched on (a copy of :attr:`stream_rows`).

        Returns
        -------
        list of tuple
        """
        return list(self.stream_rows)

    def servo_bus(self):
        """This board: what a port offers of its servo bus (:meth:`labkit.arm.BoardPort.servo_bus`).

        Returns
        -------
        BusBoard
        """
        return self

    def servo_gains(self, joint):
        """The position-loop gains of joint ``joint``'s servo, read from it (see :class:`GainBook`).

        Parameters
        ----------
        joint : int or str

        Returns
        -------
        ServoGains
        """
        return self._guard(self.gains.read, joint)

    def set_servo_gains(self, joint, **gains):
        """Write position-loop gains of joint ``joint``'s servo, checked first (see :meth:`GainBook.write`).

        Parameters
        ----------
        joint : int or str
        **gains : int or None
            ``kp``, ``ki``, ``kd``.

        Returns
        -------
        ServoGains
            The gains now.
        """
        self.gains.check(joint, **gains)  # a bad value is the caller's error, not a bus fault
        self.settle()
        return self._guard(lambda: self.gains.write(joint, **gains))

    def _bus_gripper(self):
        if self.gripper is None:
            raise OptionError(f"{self.driver.name}: expected a robot file whose [gripper] is a servo on the bus "
                              f"(bus = {{ id, zero, direction }}, open, closed, max_torque), got "
                              f"{'none' if self.robot.gripper is None else 'a hobby-servo gripper (channel, pulses)'}")
        return self.gripper

    def move_gripper(self, position, max_torque=None):
        """Send the bus gripper to servo angle ``position`` [rad] with grip limit ``max_torque`` [N m].

        Parameters
        ----------
        position : float
        max_torque : float, optional
            Default the robot file's ``max_torque``.
        """
        gripper = self._bus_gripper()
        self.settle()
        self._guard(gripper.move, position, max_torque)

    def read_gripper(self):
        """The bus gripper's present position, goal and current.

        Returns
        -------
        GripperState
        """
        gripper = self._bus_gripper()
        self.settle()
        return self._guard(gripper.read)

    def shutdown(self):
        """Write back the gains labkit changed, turn torque off and close the bus (never raises; the port's
        ``close`` calls it)."""
        self.executor._halt()
        if not self.driver.closed:
            self.gains.restore()
            if self.gripper is not None:
                self.gripper.close()
        self.driver.close()

    # -- faults ------------------------------------------------------------------------------------------
    def _guard(self, fn, *args):
        if self.fault is not None:
            raise BusFault(str(self.fault))
        try:
            return fn(*args)
        except DeviceError as exc:
            self._fail(exc)

    def _fail(self, exc):
        self.executor.segments.clear()
        self.executor.state = "HOLD"
        failed = self.driver.torque_off_quietly()
        if self.gripper is not None and not self.gripper.close():
            failed.append(self.gripper.id)
        note = "torque is off on every servo" if not failed else \
            f"torque off not acknowledged by servo(s) {', '.join(map(str, failed))}: switch the servo power off"
        self.fault = BusFault(f"{exc}; the arm is stopped and {note}")
        raise self.fault from None

    # -- the servos: what the executor asks (its Servos interface); the servos' range is the joint limits ------
    def joint_range(self, j, cal):
        """Joint ``j``'s range ``lo, hi`` [cdeg]: its limits (``cal`` is not used on a bus).

        Parameters
        ----------
        j : int
        cal : sequence of int

        Returns
        -------
        tuple of int
        """
        return self._lim[j]

    def valid(self, j, q, cal):
        """Whether ``q`` [cdeg] is within joint ``j``'s limits.

        Parameters
        ----------
        j : int
        q : float
        cal : sequence of int

        Returns
        -------
        bool
        """
        lo, hi = self._lim[j]
        return lo <= q <= hi

    def clamp(self, j, q, cal):
        """``q`` [cdeg] clamped to joint ``j``'s limits.

        Parameters
        ----------
        j : int
        q : float
        cal : sequence of int

        Returns
        -------
        float
        """
        lo, hi = self._lim[j]
        return min(max(q, lo), hi)

    def power_up(self):
        """Start where the arm is (see the module notes)."""
        self._guard(self._power_up)

    def _power_up(self):
        driver = self.driver
        driver.ping_all()
        driver.torque(False)
        reading = self._agreed_read()
        for j, (lk, q) in enumerate(zip(self.robot.links, reading.q)):
            lo, hi = lk.limits
            if not lo - 1e-9 <= q <= hi + 1e-9:
                raise BusFault(f"{driver.name}: joint {lk.name!r} rests at {math.degrees(q):.1f} deg, outside its limits "
                               f"{math.degrees(lo):.1f}..{math.degrees(hi):.1f} deg: torque stays off; move it "
                               f"inside by hand (or fix the robot file's bus zero {lk.bus.zero:g} / direction)")
        self.executor.q = [min(max(math.degrees(v) * 100, lo), hi) for v, (lo, hi) in zip(reading.q, self._lim)]
        self._write_goals([int(t) for t in reading.ticks])
        driver.set_profiles()
        driver.torque(True)
        if self.gripper is not None:
            self.gripper.start()

    def settle(self):
        """Run a virtual bus's physics up to board time."""
        self._physics.advance_to(self.executor.time)

    def frame(self):
        """A servo frame: the goal positions in one sync write, a health read every few frames."""
        self._guard(self._drive)

    def _drive(self):
        ex = self.executor
        goal = [int(lk.bus.ticks(math.radians(q / 100.0))) for lk, q in zip(self.robot.links, ex.q)]
        self._physics.advance_to(ex.time)
        if goal != self._goal:
            self._write_goals(goal)
            self.goals_sent += 1
        self._frames += 1
        if self._frames % HEALTH_FRAMES == 0 and ex.stream_hz == 0:
            self._read()

    def feedback(self):
        """``READ`` on a bus: the present positions as 10-bit counts of the servo's turn, and 0 for the pot.

        Returns
        -------
        list of int
        """
        reading = self._guard(self._read)
        res = self.robot.bus.resolution
        return [int(round(int(t) % res * 1023 / (res - 1))) for t in reading.ticks] + [0]

    def stream_frame(self, counter, t_ms):
        """A stream frame: one sync read kept in :attr:`stream_rows`; no ``FB`` line is sent.

        Parameters
        ----------
        counter : int
        t_ms : int

        Returns
        -------
        None
        """
        reading = self._guard(self._read)
        self.stream_rows.append((counter, t_ms, *reading.ticks.tolist(), *reading.current.tolist()))

    def stream_rate(self, hz):
        """A new stream starts a new table of rows.

        Parameters
        ----------
        hz : int
        """
        if hz:
            self.stream_rows = []

    # -- the bus ---------------------------------------------------------------------------------------------
    def _read(self):
        self._physics.advance_to(self.executor.time)
        self.reading = self.driver.read_state(self.executor.time)
        return self.reading

    def _agreed_read(self):
        """A sync read that the next one confirms (every joint within :data:`AGREE_TURN` of a turn), up to
        :data:`READ_TRIES` reads: the power-up pose becomes the goals, and an 8-bit checksum (Feetech) passes one
        damaged or misaligned status packet in 256."""
        tol = AGREE_TURN * self.robot.bus.resolution
        now = self._read()
        for _ in range(READ_TRIES):
            last, now = now, self._read()
            moved = [self.driver.servo(i) for i, a, b in zip(self.driver.ids, now.ticks, last.ticks)
                     if abs(int(a) - int(b)) > tol]
            if not moved:
                return now
        raise BusFault(f"{self.driver.name}: the present positions of {', '.join(moved)} differ from one sync read to "
                       f"the next after {READ_TRIES + 1} reads (is the arm moving, or are status packets damaged?); "
                       f"hold the arm still; {advice(self.driver)}")

    def _write_goals(self, goal):
        # read back from every servo before it returns (a virtual bus has run the write before it answers, so
        # its physics never runs ahead of a goal sent)
        self.driver.write_goals(goal)
        self._goal = goal


def _shutdown_at_exit(ref):
    board = ref()
    if board is not None:
        board.shutdown()


def open_bus_board(robot, device, *, protocol=None, model=None, queue=6, name=None, latency=None):
    """Open ``robot``'s servo bus on ``device`` through its SDK and put a :class:`BusBoard` in front of it.

    Parameters
    ----------
    robot : Robot or str
        A robot (file) with a ``[bus]`` table; its ``protocol`` picks the codec (:data:`BUSES`).
    device : str
        The bus adapter's serial device (or a :class:`BusEmulator`'s pseudo-terminal).
    protocol : str, optional
        The protocol the caller expects (a URL's scheme ``dynamixel://``, a ``sim://...?bus=``): the robot
        file's ``[bus] protocol`` must agree; default: the robot file's.
    model : ArmModel, optional
        The virtual arm behind a virtual bus.
    queue : int
    name : str, optional
        How messages name the bus.
    latency : float, optional
        Adapter latency in the SDK's status timeout [ms] (see :class:`BusDriver`).
    Returns
    -------
    BusBoard

    Raises
    ------
    OptionError
        The robot has no ``[bus]`` table, its protocol is not ``protocol`` or not one of :data:`BUSES`.
    DeviceError
        The bus cannot be opened, a servo does not answer, the arm rests outside its limits.
    """
    robot = Robot.load(robot)
    if robot.bus is None or (protocol is not None and robot.bus.protocol != protocol):
        want = "a [bus] table" if protocol is None else f"[bus] protocol = {protocol!r} for a {protocol} bus"
        got = "no [bus] table" if robot.bus is None else f"[bus] protocol = {robot.bus.protocol!r}"
        raise OptionError(f"expected robot {robot.name!r} to have {want}, got {got}")
    driver = bus_module(robot.bus.protocol).Driver(robot, device, name=name, latency=latency)
    try:
        return BusBoard(robot, driver, model=model, queue=queue)
    except BaseException:
        driver.close()
        raise
