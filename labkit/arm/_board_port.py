"""What the host needs of any board: :class:`BoardPort`, the one interface :class:`labkit.arm.Arm` uses.

Every board labkit drives is reached through a port that implements it: a real Arduino (its
pyserial port wrapped in :class:`labkit.arm.link.ArduinoPort`), the virtual arm (``sim://``), the
firmware in simavr (``simavr://``), and the servo buses, virtual (``sim://...?bus=``) or real
(``dynamixel://``, ``feetech://``); port wrappers such as :class:`labkit.arm.FaultyPort` pass it on.
The host sends sealed request lines and reads the board's replies as bytes (``docs/protocol.md``:
framing, sequence ids, CRC-32, all in :mod:`labkit.arm.link`), keeps its waits on the board's
clock, and asks the port for what does not travel as protocol lines: the servos' own readings
on a servo bus (a sync read, the stream frames) and, on a simulated board, the simulated arm.

The host never asks a port what kind it is: a new board kind is a new class with these members.

Examples
--------
>>> import serial
>>> from labkit.arm.urlhandler import register
>>> register()
>>> port = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.5)
>>> isinstance(port, BoardPort), port.read_servos() is None, port.virtual_model is not None
(True, True, True)
>>> port.close()
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["BoardPort"]


@runtime_checkable
class BoardPort(Protocol):
    """A port to a labkit board, as the host uses it (see the module notes).

    pyserial's byte interface (``write``, ``read``, ``in_waiting``, ``timeout``, ``close``) carries
    the protocol's lines; the clock members say which clock the board keeps; ``read_servos`` and
    ``virtual_model`` are what a board offers beside its lines.

    Attributes
    ----------
    timeout : float or None
        Read timeout [s]: of board time on a ``"lockstep"`` port, of the wall clock otherwise; the
        host sets it before each read.
    in_waiting : int
        Bytes the board has sent that the host has not read.
    board_time : float or None
        The board's clock [s] when the port knows it (a simulated board), brought up to date;
        ``None``: the host keeps its own wall clock (a real board).
    clock : str
        ``"lockstep"`` (board time passes only while the host waits on the port: ``read`` or
        ``sleep``) or ``"realtime"`` (it passes on its own, ``time_scale`` board seconds per second).
    time_scale : float
        Board seconds per wall-clock second on a ``"realtime"`` port (1 on a real board).
    virtual_model : ArmModel or None
        The simulated arm behind the port (true joints, offsets, ruler), ``None`` for real hardware.
    """

    timeout: float | None

    @property
    def in_waiting(self) -> int: ...

    @property
    def board_time(self) -> float | None: ...

    @property
    def clock(self) -> str: ...

    @property
    def time_scale(self) -> float: ...

    @property
    def virtual_model(self): ...

    def write(self, data) -> int:
        """Send bytes to the board.

        Parameters
        ----------
        data : bytes-like
            A sealed request line (``docs/protocol.md``).

        Returns
        -------
        int
            ``len(data)``.
        """

    def read(self, size=1) -> bytes:
        """Bytes the board sent (its reply, event and ``FB`` lines), waiting up to ``timeout``.

        Parameters
        ----------
        size : int
            Largest number of bytes.

        Returns
        -------
        bytes
        """

    def sleep(self, seconds) -> None:
        """Let board time pass (lockstep: the board runs it; else the host sleeps).

        Parameters
        ----------
        seconds : float
            Board time [s].
        """

    def read_servos(self):
        """Joint feedback read from the servos themselves, or ``None`` when the board has no such path.

        Returns
        -------
        BusReading or None
            On a servo bus one sync read now: present positions ``q`` [rad] and ``ticks``, present
            ``current`` [A] (the load); ``None`` on a board whose joints come back only as protocol
            lines (``READ``, ``FB``: the feedback pots of hobby servos).

        Raises
        ------
        DeviceError
            The bus failed (a :class:`labkit.arm.bus.BusFault`).
        """

    def servo_stream(self):
        """The stream frames the board read from its servos since ``STREAM`` was switched on, or ``None``.

        Returns
        -------
        list of tuple or None
            On a servo bus, where the board takes each frame as a sync read at its own clock and sends
            no ``FB`` line: ``(counter, t_ms, ticks..., currents...)`` per frame, ticks [ticks], currents
            [A]; ``None`` on a board whose frames travel as ``FB`` lines.
        """

    def servo_bus(self):
        """The servo bus behind the port, or ``None`` when the board drives hobby servos.

        Returns
        -------
        BusBoard or None
            On a servo bus the host-side board, which reads and writes what the servos keep beside their
            goals (their position-loop gains, the gripper); ``None`` on a board of hobby servos.
        """

    def close(self) -> None:
        """Close the port (a bus board turns torque off first)."""
