"""What :class:`labkit.arm.Arm` offers of the servos themselves: the gripper, and on a servo bus the position-loop gains.

A hobby-servo gripper takes a pulse width (``GRIP``, a protocol line the board checks); a bus
gripper is a servo on the bus, moved to an angle with a grip limit (:mod:`labkit.arm.bus`). A servo
on a bus (Dynamixel, Feetech) runs its own position loop: :meth:`ServoMethods.servo_gains` reads
its gains and :meth:`ServoMethods.set_servo_gains` writes new ones, checked against the servo's
range before anything is sent; the board writes the old values back when the arm is closed.
They go through the port's servo bus (:meth:`labkit.arm.BoardPort.servo_bus`), not protocol lines.
"""

from __future__ import annotations

from labkit.exceptions import DeviceError, OptionError
from labkit.robot import BusGripper
from labkit.arm.link._inputs import finite

__all__ = ["ServoMethods"]


class ServoMethods:
    """The servo operations of :class:`labkit.arm.Arm` (it derives from this class; see the module notes)."""

    # -- the gripper -----------------------------------------------------------------------------
    def grip(self, us):
        """Gripper pulse width [us].

        Parameters
        ----------
        us : float
            Pulse width sent to the gripper servo [us] (rounded to an integer); the board
            checks it against the gripper channel's range.

        Raises
        ------
        OptionError
            Not a finite number (nothing is sent).
        CommandRejected
            Outside the gripper's pulse range (``ERR 5 RANGE``).
        """
        self._transact("GRIP", int(round(finite("us", us, lo=400.0, hi=2600.0, unit="us"))))  # RC pulses (protocol 4.2)

    def open_gripper(self):
        """Open the gripper (robot file's ``open_us``; a bus gripper: its ``open`` angle)."""
        g = self._gripper()
        if isinstance(g, BusGripper):
            self.move_gripper(g.open)
        else:
            self.grip(g.open_us)

    def close_gripper(self, *, max_torque=None):
        """Close the gripper (robot file's ``closed_us``; a bus gripper: its ``closed`` angle, squeezing what it
        holds with at most ``max_torque``).

        Parameters
        ----------
        max_torque : float, optional
            Grip limit of a bus gripper [N m]; default the robot file's ``max_torque``. A hobby-servo gripper has
            none (``OptionError`` if given).
        """
        g = self._gripper()
        if isinstance(g, BusGripper):
            self.move_gripper(g.closed, max_torque=max_torque)
        elif max_torque is not None:
            raise OptionError(f"expected no max_torque for the hobby-servo gripper of {self.robot.name!r} (it has no "
                              f"limit to set), got {max_torque!r}")
        else:
            self.grip(g.closed_us)

    def move_gripper(self, position, *, max_torque=None):
        """Send a bus gripper's servo to ``position`` [rad] with a grip limit (the servo's current or torque limit).

        Parameters
        ----------
        position : float
            Servo angle [rad] within the robot file's ``open`` .. ``closed``.
        max_torque : float, optional
            Grip limit [N m], within the servo's stall torque; default the robot file's ``max_torque``.

        Raises
        ------
        OptionError
            ``position`` outside the gripper's travel, ``max_torque`` outside the servo's range, or no bus gripper in
            the robot file (nothing is written).
        DeviceError
            Not an arm on a servo bus, or the bus failed.
        """
        bus = self._servo_bus("move its gripper servo")
        self._wire.io(lambda: bus.move_gripper(position, max_torque))

    def read_gripper(self):
        """A bus gripper's present position [rad], goal [rad] and current [A] (one read of its servo).

        Returns
        -------
        GripperState
            :class:`labkit.arm.bus.GripperState`.
        """
        bus = self._servo_bus("read its gripper servo")
        return self._wire.io(bus.read_gripper)

    def _gripper(self):
        if self.robot.gripper is None:
            raise DeviceError(f"robot {self.robot.name} has no gripper in its robot file")
        return self.robot.gripper

    # -- a bus servo's position loop -----------------------------------------------------------------
    def _servo_bus(self, what):
        bus = self._wire.io(lambda: self.port.servo_bus())
        if bus is None:
            raise DeviceError(f"{self.name}: expected an arm on a servo bus (sim://...?bus=, dynamixel://, feetech://) "
                              f"to {what}, got a board of hobby servos (their loop is inside the servo, out of reach)")
        return bus

    def servo_gains(self):
        """The position-loop gains of every joint's servo on a servo bus, read from the servos.

        Returns
        -------
        dict of str to ServoGains
            Joint name -> :class:`labkit.arm.bus.ServoGains` (``kp``, ``ki``, ``kd`` as register values: Dynamixel
            Position P/I/D Gain, Feetech P/I/D coefficient).

        Raises
        ------
        DeviceError
            Not an arm on a servo bus, or the bus failed.

        Examples
        --------
        >>> with Arm("tests/arm/bus/omx_test.toml", "sim://tests/arm/bus/omx_test.toml?bus=dynamixel&clock=lockstep") \\
        ...         as arm:                                                                     # doctest: +SKIP
        ...     arm.servo_gains()["shoulder"]
        ServoGains(kp=800, ki=0, kd=0)
        """
        bus = self._servo_bus("read its servos' gains")
        return {name: self._wire.io(lambda j=j: bus.servo_gains(j)) for j, name in enumerate(self.robot.joint_names)}

    def set_servo_gains(self, joint, *, kp=None, ki=None, kd=None):
        """Write position-loop gains of one joint's servo on a servo bus (restored when the arm is closed).

        Parameters
        ----------
        joint : int or str
            Joint index or name.
        kp, ki, kd : int, optional
            New register values (``None``: unchanged); each a whole number within the servo's range
            (Dynamixel XM430: 0..16383; Feetech STS3215: 0..254).

        Returns
        -------
        ServoGains
            The servo's gains now (read back).

        Raises
        ------
        OptionError
            An unknown joint or a gain outside the servo's range: the message names the servo, its joint and the
            range, and nothing is written.
        DeviceError
            Not an arm on a servo bus, or the bus failed.
        """
        bus = self._servo_bus("set its servos' gains")
        return self._wire.io(lambda: bus.set_servo_gains(joint, kp=kp, ki=ki, kd=kd))
