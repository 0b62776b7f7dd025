"""Host link to the arm: a pyserial client of protocol v2 (``docs/protocol.md``).

:class:`Arm` opens a real board (``/dev/ttyACM0``, ``COM3``, auto-detected), the virtual arm
(``sim://``), the firmware simulator (``simavr://``) or a servo bus (``dynamixel://``,
``feetech://``, ``sim://...?bus=``: a host-side board, :mod:`labkit.arm.bus`), all through one interface
(:class:`labkit.arm.BoardPort`: it never asks which kind of board it has), waits for the board's
``READY`` after the reset-on-open, shakes hands, and offers the lab operations in SI units: joint
moves (checked against the robot file's limits and servo ranges *before* anything is sent),
Cartesian moves through :func:`labkit.kinematics.ik`, trajectories streamed as polynomial
segments, gripper, stop, joint read-back and feedback streams into pandas.

Reliability rules (``docs/link.md``): every request carries a sequence id and a CRC-32; board lines
with a bad CRC are dropped and counted, never used; the reply to a state-changing request echoes
the CRC of what the board parsed and a different echo stops the arm; idempotent requests are
retried; a motion request (``MOVE``, ``SEG``) whose reply is lost is never blindly repeated: the
host asks ``STATUS`` (``last=``, the sequence id of the last state-changing request run) whether it
was executed and resends only if it was not; a request the host never had acknowledged showing up
there stops the arm; anything that cannot be settled raises :class:`~labkit.exceptions.DeviceError`.

Examples
--------
>>> with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
...     arm.move_joints([0.5, 0.8, 0.3], wait=True)
...     q = arm.read_joints()
>>> np.allclose(q, [0.5, 0.8, 0.3], atol=0.02)
True
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import DeviceError, OptionError
from labkit.robot import joints_to_display
from labkit.arm._protocol import WireUnits, check_joint_count, wire_calibrations, wire_speed_limits
from labkit.arm.link._replies import parse_ping, parse_read, parse_status, parse_stop
from labkit.arm.link._wire import Wire
from labkit.arm.link._segments import (check_segment_lines, check_segment_positions, check_segment_speeds,
                                       feed_segments, move_duration_ms, move_segment, segments_from_trajectory)
from labkit.arm.link._feedback import joints_from_counts, record_stream, settle_tolerance
from labkit.arm.link._ports import arm_robot, board_port, first_arduino, handshake, open_port
from labkit.arm.link._inputs import finite, joint_vector, reply_timeout, retry_count, speed_limit_lists
from labkit.arm.link._servos import ServoMethods

__all__ = ["Arm"]


def _on_wire(attr, doc, convert=None):
    """A property of :class:`Arm` reading (and with ``convert``, setting) ``attr`` of its wire object."""

    def get(self):
        return getattr(self._wire, attr)

    def set_(self, value):
        setattr(self._wire, attr, convert(value))

    return property(get, set_ if convert else None, doc=doc)


class Arm(ServoMethods):
    """A connection to a labkit arm board (real, virtual or simulated firmware).

    Parameters
    ----------
    robot : Robot or str or None
        The robot (name, file, :class:`Robot`) whose servo calibrations and limits the host enforces (a
        ``sim://`` URL naming none simulates it); ``None`` or a URL alone (``Arm("sim://<robot>")``): the one it names.
    port : str or serial-like, optional
        Device name (``/dev/ttyACM0``, ``COM3``), URL (``sim://``, ``simavr://``, ``dynamixel://``,
        ``feetech://``, any pyserial URL), an open :class:`BoardPort` or an open pyserial-like port to a real
        board (wrapped in an :class:`~labkit.arm.link.ArduinoPort`); ``None`` auto-detects an Arduino.
    baudrate : int
    timeout : float
        Reply timeout of one request attempt [s of the link's clock: board time on ``sim://`` and
        ``simavr://``, see :meth:`sleep`].
    retries : int
        Extra attempts of a request whose reply was lost or garbled.
    boot_wait : float
        How long to wait for the board's ``READY`` after opening [s] (a real Uno resets when the port opens
        and needs about 1.6 s); without it the host still tries ``HELLO`` once before giving up.
    sync_calibration : bool
        Send the robot file's servo calibrations (``CAL``) after the handshake.
    check_moves : bool
        After each acknowledged ``MOVE``, read the commanded joints back with ``STATUS`` and raise if
        they differ from what was sent (a second check besides the reply's echo).

    Attributes
    ----------
    port, name, timeout, retries, stats, events, info
        The link's state, kept by the arm's wire object (the request/retry layer of ``_wire.py``): the open
        port, its name, the reply timeout [s] and retry count (both settable), the :class:`LinkStats`
        counters, the ``EV`` lines received and the :class:`BoardInfo` of the handshake.
    virtual_model : ArmModel or None
        The simulated arm behind a ``sim://`` or ``simavr://?physics=`` port (true joints, ruler); else ``None``.

    Raises
    ------
    OptionError
        ``robot`` is ``None`` and the port is not a ``sim://<robot>`` URL.
    RobotError
        The robot has more joints than the board protocol carries (:data:`labkit.arm.MAX_JOINTS`); nothing is
        opened.
    DeviceError
        No port found, the port cannot be opened, no handshake, wrong protocol version or joint count.
    """

    def __init__(self, robot, port=None, *, baudrate=115200, timeout=0.25, retries=6, boot_wait=3.0,
                 sync_calibration=True, check_moves=True):
        timeout, retries = reply_timeout(timeout), retry_count(retries)
        boot_wait = finite("boot_wait", boot_wait, lo=0.0, hi=600.0, unit="s")
        #: the robot file whose servo calibrations and limits the host enforces
        self.robot, port = arm_robot(robot, port)
        check_joint_count(self.robot)  # more joints than a request line carries: refused before the port is opened
        #: the units of the joints' positions on the wire (centidegrees; an RC linear servo: 1/18000 of its stroke)
        self._units = WireUnits(self.robot)
        #: read the commanded joints back after every MOVE (besides the echo of the reply)
        self.check_moves = bool(check_moves)
        opened = self._open(port, baudrate, self.robot)
        name = getattr(opened, "port", None) or getattr(opened, "name", repr(opened))
        self._wire = Wire(opened, name=name, timeout=timeout, retries=retries)
        try:
            handshake(self, boot_wait)
            if sync_calibration:
                self.sync_calibration()
        except BaseException:
            self.close()
            raise

    # -- opening ------------------------------------------------------------------------
    @staticmethod
    def _open(port, baudrate, robot):
        from labkit.arm.urlhandler import register

        register()
        if port is not None and not isinstance(port, (str, bytes)):
            return board_port(port)
        return open_port(first_arduino() if port is None else port, baudrate, robot)

    def close(self):
        """Close the port (never raises, even if the port has vanished)."""
        self._wire.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"Arm({self.robot.name!r}, {self.name!r})"

    # -- the link's state, held by the wire object -------------------------------------------------
    port = _on_wire("port", "The open port (a :class:`BoardPort`, pyserial-like; ``None`` after :meth:`close`).")
    name = _on_wire("name", "Port name (``/dev/ttyACM0``, ``sim://...``) used in error messages.")
    timeout = _on_wire("timeout", "Reply timeout of one request attempt [s] (settable: finite, 1e-4..60 s).", reply_timeout)
    retries = _on_wire("retries", "Extra attempts of a request whose reply was lost or garbled (settable: 0..1000).",
                       retry_count)
    stats = _on_wire("stats", "Counters of the wire (:class:`LinkStats`): bad lines, retries, frames lost...")
    events = _on_wire("events", "``EV`` lines received so far, as ``(name, fields)`` tuples, oldest first.")
    info = _on_wire("info", "The board's ``HELLO`` answer (:class:`BoardInfo`).")

    @property
    def virtual_model(self):
        """The simulated arm behind the port, or ``None`` for a real board.

        The :class:`ArmModel` of a virtual arm (``sim://``, also on a virtual servo bus ``?bus=``) or of the
        firmware simulator with physics (``simavr://?physics=...``), also through port wrappers such as
        :class:`FaultyPort`. It knows what a real arm hides: the true joints (``true_q``), the injected zero
        offsets and a ruler (``ruler(readings)`` [m]).

        Returns
        -------
        ArmModel or None

        Examples
        --------
        >>> with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
        ...     arm.virtual_model.ruler(2).shape
        (2, 3)
        """
        port = self.port
        return None if port is None else port.virtual_model

    def _clock(self):
        return self._wire.clock()

    def _transact(self, command, *args, **kwargs):
        return self._wire.transact(command, *args, **kwargs)

    def sleep(self, seconds):
        """Wait ``seconds`` of board time while handling incoming lines.

        Parameters
        ----------
        seconds : float
            Time to wait [s], finite, 0..86400 s, on the board clock: ``port.board_time`` on ``sim://``
            and ``simavr://`` (in lockstep the board runs only while the host waits).

        Raises
        ------
        OptionError
            ``seconds`` not a finite number within 0..86400 (nothing waits forever).
        """
        seconds = finite("seconds", seconds, lo=0.0, hi=86400.0, unit="s")
        end = self._clock() + seconds
        while (left := end - self._clock()) > 0:
            self._wire.pump(min(left, 0.05))

    # -- queries -----------------------------------------------------------------------------
    def ping(self):
        """Board clock [s] (also keeps the host-silence timer alive).

        Returns
        -------
        float
            Board time since reset [s] (millisecond resolution).

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        return self._transact("PING", parse=parse_ping)

    def status(self, *, retries=None):
        """The board's state (commanded joints, queue, counters) as a :class:`Status`.

        Parameters
        ----------
        retries : int, optional
            Resend attempts after a lost or garbled reply; default ``4 * self.retries + 4`` (the
            reply is long, so it is the most likely to be damaged on a noisy line).

        Returns
        -------
        Status

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        queue = self.info.queue if self.info is not None else None
        if retries is None:  # the longest reply (about 150 bytes): the first to be hit on a noisy line
            retries = 4 * self.retries + 4
        st = self._transact("STATUS", parse=lambda fields: parse_status(fields, self.robot.n, queue, self._units),
                            retries=retries)
        if self._wire.last_seq is not None:
            self._wire.check_last(st.last)
        return st

    def _verify_status(self, seq=None):
        """STATUS with a larger retry budget; with ``seq`` (a request whose reply was lost) settles whether it ran."""
        queue = self.info.queue if self.info is not None else None
        st = self._transact("STATUS", parse=lambda fields: parse_status(fields, self.robot.n, queue, self._units),
                            retries=4 * self.retries + 4)
        ran = self._wire.check_last(st.last, pending=seq) if self._wire.last_seq is not None else False
        return st, ran

    def commanded_joints(self):
        """Joint values the servos are commanded to now, shape (n,) [rad].

        Returns
        -------
        ndarray, shape (n,)
            Commanded joint values [rad] (from :meth:`status`).
        """
        return self.status().q

    def read_adc(self):
        """Raw feedback counts of every joint and the user pot (``READ``), shape (n + 1,).

        Returns
        -------
        ndarray of int, shape (n + 1,)
            ADC counts 0..1023 of joints 1..n, then the user pot.

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        return self._transact("READ", parse=lambda fields: parse_read(fields, self.robot.n))

    def read_joints(self):
        """Joint values sensed by the feedback pots (on a servo bus: the present positions), shape (n,) [rad].

        Returns
        -------
        ndarray, shape (n,)
            From :meth:`read_adc` through each joint's servo calibration, or one sync read of a servo bus.
        """
        if self.robot.bus is not None:
            return self._read_servos().q
        adc = self.read_adc()
        return joints_from_counts(self.robot, adc)

    def read_load(self):
        """Present current of every joint's servo on a servo bus (one sync read), the load signal; hobby servos
        (no ``[bus]`` table in the robot file) report none: :class:`DeviceError`, as when the bus fails.

        Returns
        -------
        ndarray, shape (n,)
            Signed current [A] per joint.
        """
        if self.robot.bus is None:
            raise DeviceError(f"{self.name}: expected an arm on a servo bus ([bus] in the robot file) to read the "
                              f"load of, got {self.robot.name!r} with hobby servos (they report no current)")
        return self._read_servos().current

    def _read_servos(self):
        """One sync read of a servo bus through the port (:meth:`BoardPort.read_servos`)."""
        reading = self._wire.io(lambda: self.port.read_servos())
        if reading is None:
            raise DeviceError(f"{self.name}: expected a port on a servo bus (sim://...?bus=, dynamixel://, feetech://) "
                              f"to read present positions and currents from, got a board that reports its joints "
                              f"only as READ lines")
        return reading

    # -- configuration ---------------------------------------------------------------------
    def speed_limits(self):
        """Per-joint speed [units/s] and acceleration [units/s^2] limits as sent to the board (0: unchecked).

        Returns
        -------
        vmax, amax : list of int
            From the robot file (:func:`wire_speed_limits`).
        """
        return wire_speed_limits(self.robot)

    def sync_calibration(self, *, speed_limits=None):
        """Send the robot file's servo calibrations (``CAL``) and speed limits (``LIMITS``) to the board (RAM only).

        Parameters
        ----------
        speed_limits : tuple of two lists of int, optional
            ``(vmax, amax)`` to send instead of the robot file's, in the form :meth:`speed_limits` returns (0: unchecked;
            ``record_step`` lifts them for a step); nothing on the host changes, pass the same to :meth:`run_trajectory`.
        """
        vmax, amax = speed_limit_lists(self.robot, speed_limits)
        for j in range(self.robot.n):
            self._transact("LIMITS", j, vmax[j], amax[j])
        joints, gripper = wire_calibrations(self.robot)
        for lk, row in zip(self.robot.links, joints):
            if row is not None:
                self._transact("CAL", lk.servo.channel, *row)
        if gripper is not None:
            self._transact("CAL", self.robot.gripper.channel, *gripper)

    def set_host_timeout(self, seconds):
        """Host-silence timeout of the board [s] (0 disables it).

        Parameters
        ----------
        seconds : float
            Time without a host line after which the board holds [s], sent rounded to ms; 0: off, else 0.05..60.

        Raises
        ------
        OptionError
            Not a finite number, or neither 0 nor within 0.05..60 s (nothing is sent).
        """
        seconds = finite("seconds", seconds, lo=0.0, hi=60.0, unit="s")
        if 0 < seconds < 0.05:
            raise OptionError(f"expected seconds 0 (off) or 0.05..60 s, got {seconds:g}")
        self._transact("TIMEOUT", int(round(seconds * 1000)))

    # -- motion ----------------------------------------------------------------------------
    def move_joints(self, q, *, duration=None, wait=False, tol=math.radians(1.0), max_wait=10.0):
        """Move all joints at once (``MOVE``: a rest-to-rest cubic the board runs); returns when it ends.

        Parameters
        ----------
        q : array_like, shape (n,)
            Joint values [rad]; checked against the joint limits and servo ranges before anything is sent.
        duration : float, optional
            Duration of the move [s]; by default the shortest one the robot file's speed and acceleration
            limits allow. Checked against them before sending, as the board checks it.
        wait : bool
            Wait until the sensed joints are within ``tol`` [rad] of ``q`` (at most ``max_wait`` s).
        tol : float
            Settling tolerance per joint [rad] when ``wait``.
        max_wait : float
            Longest wait for settling [s of board time] when ``wait``.

        Raises
        ------
        JointLimitError
            A joint outside its limits or servo range (nothing is sent).
        TrajectoryError
            ``duration`` too short for a joint's speed or acceleration limit (nothing is sent).
        DeviceError
            The board rejected or did not acknowledge the move, or (``wait``) the joints did not settle in time.
        """
        q = joint_vector(self.robot, q)
        target = self._units.positions(q)
        before = self._verify_status()[0]
        now = self._units.positions(before.q)
        if duration is None:
            dur = move_duration_ms(now, target, *self.speed_limits())
        else:
            dur = int(round(finite("duration", duration, lo=0.001, hi=60.0, unit="s") * 1000))
            check_segment_speeds(self.robot, [move_segment(now, target, dur)], *self.speed_limits())
        self._transact("MOVE", *target, dur, motion=True, verify=lambda seq: self._verify_status(seq)[1])
        # first let most of the move pass (a STATUS costs a long reply, often resent on a noisy line), in steps
        # that feed the host-silence timer (a STATUS at least every 40 % of it), then poll for its end
        step = dur / 1000.0 if not before.timeout else min(dur / 1000.0, 0.4 * before.timeout)
        end = self._wire.clock() + 0.9 * dur / 1000.0
        while (left := end - self._wire.clock()) > 0:
            self.sleep(min(left, step))
            if left > step:
                self._verify_status()
        while (st := self._verify_status()[0]).state == "RUN":  # STATUS also feeds the host-silence timer
            self.sleep(min(0.05, dur / 1000.0))
        if st.state == "HOLD":
            raise DeviceError(f"{self.name}: the board halted MOVE {' '.join(map(str, target))} (host-silence timeout)")
        if self.check_moves:
            got = self._units.positions(st.q)
            if got != target:
                self._wire.hold(f"after MOVE {' '.join(map(str, target))} the board is commanded to "
                                f"{' '.join(map(str, got))} (wire units)")
        if wait:
            self.wait_settled(q, tol=tol, max_wait=max_wait)

    def wait_settled(self, q, *, tol=None, max_wait=10.0, interval=0.05):
        """Wait until the sensed joints stay within ``tol`` of ``q`` for two reads; returns them.

        Parameters
        ----------
        q : array_like, shape (n,)
            Target joint values [rad | m].
        tol : float or array_like, shape (n,), optional
            Largest allowed ``|sensed - q|`` per joint [rad | m]; default :func:`settle_tolerance` (1 deg,
            1 mm, or three feedback counts where a count is coarser).
        max_wait : float
            Give up after this much board time [s].
        interval : float
            Board time between reads [s].

        Returns
        -------
        ndarray, shape (n,)
            The last sensed joint values [rad].

        Raises
        ------
        DeviceError
            The joints did not settle within ``max_wait``.
        """
        q = joint_vector(self.robot, q)
        if tol is None:
            tol = settle_tolerance(self.robot)
        else:
            tol = np.array([finite("tol", t, lo=0.0, unit="rad | m") for t in np.ravel(tol)])
            if tol.size not in (1, self.robot.n):
                raise OptionError(f"expected tol as one number or {self.robot.n} (one per joint), got {tol.size}")
        max_wait = finite("max_wait", max_wait, lo=0.0, hi=86400.0, unit="s")
        interval = finite("interval", interval, lo=1e-3, hi=60.0, unit="s")
        end = self._clock() + max_wait
        hits = 0
        sensed = None
        while self._clock() < end or sensed is None:  # at least one read
            sensed = self.read_joints()
            hits = hits + 1 if np.all(np.abs(sensed - q) <= tol) else 0
            if hits >= 2:
                return sensed
            self.sleep(interval)
        raise DeviceError(f"{self.name}: joints did not settle within {max_wait} s at tolerance "
                          f"{joints_to_display(self.robot, tol).round(2)} (sensed "
                          f"{joints_to_display(self.robot, sensed).round(2)}, commanded "
                          f"{joints_to_display(self.robot, q).round(2)}; deg | mm)")

    def move_to(self, target, *, branch=None, wait=False):
        """Move the tool to a Cartesian ``target`` through :func:`labkit.kinematics.ik` (nearest branch by default).

        Parameters
        ----------
        target : array_like
            Tool target for :func:`labkit.kinematics.ik`: position (3,) [m] for the
            3-DOF arm.
        branch : str, optional
            IK branch (e.g. ``"elbow_up"``); default: the solution nearest the
            commanded joints.
        wait : bool
            Wait until the joints settle (see :meth:`move_joints`).

        Returns
        -------
        ndarray, shape (n,)
            The joint values commanded [rad].

        Raises
        ------
        UnreachableError
            The target is out of reach (nothing is sent).
        JointLimitError, DeviceError
            As for :meth:`move_joints`.
        """
        from labkit.kinematics import ik

        current = self.commanded_joints()
        q = ik(self.robot, target, branch=branch, q_near=None if branch else current)
        self.move_joints(q, wait=wait)
        return q

    def stop(self):
        """Stop at once: end any trajectory, clear the queue, hold; returns the held joints [rad].

        Returns
        -------
        ndarray, shape (n,)
            Joint values the board holds [rad] (centidegree resolution).

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        return self._transact("STOP", parse=lambda fields: parse_stop(fields, self.robot.n, self._units))

    def run_trajectory(self, traj, *, order=3, min_duration=0.05, progress=None, wait=True, speed_limits=None):
        """Stream a trajectory to the board's segment queue, keeping it fed.

        Parameters
        ----------
        traj : labkit.motion.Trajectory or list of segments
            A sampled trajectory (checked against the joint limits first) or ``(dur_ms, order,
            coefficients)`` tuples from :func:`segments_from_trajectory`.
        order : {3, 5}
            Polynomial order of the segments made from a sampled trajectory.
        min_duration : float
            Shortest segment made from a sampled trajectory [s].
        progress : callable or bool, optional
            ``progress(done, total)`` after each queued segment, or ``True`` for a tqdm bar.
        wait : bool
            Wait for the board's ``EV DONE`` after the last segment.
        speed_limits : tuple of two lists of int, optional
            ``(vmax, amax)`` the board holds (sent with :meth:`sync_calibration`) to check the segments against
            instead of the robot file's (:meth:`speed_limits`).

        Returns
        -------
        TrajectoryReport

        Raises
        ------
        JointLimitError
            A sample outside the joint limits or servo ranges, or a segment leaving them between samples
            (the board's check; nothing is sent).
        TrajectoryError
            A segment faster than a joint's speed or acceleration limit (the board's check; nothing is sent).
        OptionError
            A segment's ``SEG`` line longer than ``MAX_LINE`` (a sampled trajectory's are split to fit, down to
            pieces of 1 ms: :func:`segments_from_trajectory`); nothing is sent.
        DeviceError
            A segment rejected or lost, or the board held (host-silence timeout).
        """
        if isinstance(traj, (list, tuple)):
            segs = list(traj)
        else:
            self.robot.check_limits(np.asarray(traj.q))
            for row in np.asarray(traj.q):
                joint_vector(self.robot, row)
            segs = segments_from_trajectory(traj, order=order, min_duration=min_duration, units=self._units)
        check_segment_positions(self.robot, segs)
        check_segment_speeds(self.robot, segs, *speed_limit_lists(self.robot, speed_limits))
        check_segment_lines(segs)
        return feed_segments(self, segs, progress=progress, wait=wait)

    # -- feedback ---------------------------------------------------------------------------
    def stream(self, duration, *, hz=50):
        """Record the feedback stream for ``duration`` seconds of board time.

        Parameters
        ----------
        duration : float
            Recording time [s of board time].
        hz : int
            Frame rate the board streams at [Hz], 1..200.

        Returns
        -------
        pandas.DataFrame
            One row per frame received intact: ``t`` [s, board clock],
            ``counter``, ``received`` (host UTC timestamp), ``adc<i>``,
            ``pot`` and the sensed joints ``q_<name>`` [rad] (on a servo bus: ``tick<i>``, ``q_<name>`` and
            ``current_<name>`` [A] instead of ``adc<i>``, ``pot``). ``df.attrs``
            holds ``expected`` (frames the board sent in the window, from its
            clock), ``lost`` (expected but not received intact), ``rejected``
            (lines dropped as corrupt while streaming) and ``hz``.

        Raises
        ------
        OptionError
            ``duration`` not > 0 s, or ``hz`` not a whole number in 1..200 (a ``ValueError``).
        """
        return record_stream(self.robot, self._wire, duration, hz)
