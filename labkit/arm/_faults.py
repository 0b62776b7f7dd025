"""Fault injection for link tests: a serial-port wrapper that corrupts, drops, delays, disconnects.

Wrap any pyserial-like port (a ``sim://`` port, a real one) and hand the
wrapper to :class:`labkit.arm.Arm`. Every fault is drawn from a seeded
generator and counted, so a test can check that each one was either survived
or reported.

At 1 % corrupted and 0.5 % dropped bytes a third of the replies arrive damaged, so the
example gives the link more attempts per request than the default 6 (seven losses in a row
happen in about 7 % of transactions at that rate).

Examples
--------
>>> import serial
>>> from labkit.arm.urlhandler import register
>>> from labkit.arm import Arm
>>> register()
>>> raw = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.05)
>>> port = FaultyPort(raw, FaultConfig(seed=1, corrupt=0.01, drop=0.005))
>>> with Arm("arduino_arm_3dof", port, timeout=0.05, retries=20) as arm:
...     t = arm.ping()
>>> t > 0
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from serial import SerialException

from labkit.exceptions import DeviceError, OptionError

__all__ = ["PortWrapper", "FaultConfig", "FaultyPort", "Direction"]


class Direction(str, Enum):
    """Which way faults apply: bytes the host ``READ``s, bytes it ``WRITE``s, or ``BOTH``."""

    READ = "read"
    WRITE = "write"
    BOTH = "both"


@dataclass(frozen=True)
class FaultConfig:
    """What to inject (probabilities per byte; all seeded).

    Attributes
    ----------
    seed : int
    corrupt : float
        Probability that a byte is replaced by a different random byte.
    drop : float
        Probability that a byte is lost.
    delay : float
        Probability that a read or write call is held up by ``delay_s``.
    delay_s : float
        Length of a delay [s of board time when the port has ``sleep``].
    duplicate : float
        Probability that a write call (a request line of the host) reaches the port twice, as a
        line repeated by a flaky adapter or a retry below the host would (each copy damaged on its own).
    disconnect_after : float
        The port vanishes (every call raises ``SerialException``) after this
        many bytes have been written by the host (``inf``: never).
    direction : Direction
    """

    seed: int = 0
    corrupt: float = 0.0
    drop: float = 0.0
    delay: float = 0.0
    delay_s: float = 0.05
    duplicate: float = 0.0
    disconnect_after: float = math.inf
    direction: Direction = Direction.BOTH

    def __post_init__(self):
        for name in ("corrupt", "drop", "delay", "duplicate"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise OptionError(f"expected {name} as a probability in [0, 1], got {v!r}")
        try:
            object.__setattr__(self, "direction", Direction(self.direction))
        except ValueError:
            raise OptionError(f"expected direction one of {[d.value for d in Direction]}, got {self.direction!r}") from None


class _Disconnected(DeviceError, SerialException):
    """The injected disconnect: a :class:`DeviceError` that is also pyserial's ``SerialException``.

    A vanished real port raises ``SerialException``; the wrapper keeps that contract.
    """


@dataclass
class FaultCounts:
    """How many faults were injected, per kind and direction."""

    corrupted: dict = field(default_factory=lambda: {"read": 0, "write": 0})
    dropped: dict = field(default_factory=lambda: {"read": 0, "write": 0})
    delayed: int = 0
    duplicated: int = 0
    disconnected: bool = False


class PortWrapper:
    """Base of serial-port wrappers: every attribute is forwarded to the wrapped port.

    Subclasses override what they intercept (``read``, ``write`` ...); the
    ``timeout`` property is forwarded explicitly so that setting it reaches the
    wrapped port instead of shadowing it.
    """

    def __init__(self, port):
        self._port = port

    def __getattr__(self, name):
        return getattr(self._port, name)

    @property
    def timeout(self):
        return self._port.timeout

    @timeout.setter
    def timeout(self, value):
        self._port.timeout = value


class FaultyPort(PortWrapper):
    """A serial port wrapper injecting the faults of a :class:`FaultConfig`.

    Attributes not defined here (``board``, ``clock``, ``port`` ...) are
    forwarded to the wrapped port.
    """

    def __init__(self, port, config=FaultConfig()):
        super().__init__(port)
        self.config = config
        self.counts = FaultCounts()
        self._rng = np.random.default_rng(config.seed)
        self._written = 0

    def _alive(self):
        if self.counts.disconnected:
            raise _Disconnected("device disconnected (injected fault)")

    def _mangle(self, data, way):
        cfg = self.config
        if cfg.direction not in (Direction.BOTH, Direction(way)) or not data:
            return data
        arr = np.frombuffer(bytes(data), dtype=np.uint8).copy()
        hit = self._rng.random(arr.size) < cfg.corrupt
        if hit.any():
            arr[hit] ^= self._rng.integers(1, 256, hit.sum()).astype(np.uint8)
            self.counts.corrupted[way] += int(hit.sum())
        keep = self._rng.random(arr.size) >= cfg.drop
        self.counts.dropped[way] += int((~keep).sum())
        return arr[keep].tobytes()

    def _maybe_delay(self):
        if self.config.delay and self._rng.random() < self.config.delay:
            self.counts.delayed += 1
            sleeper = getattr(self._port, "sleep", None)
            if sleeper is not None:
                sleeper(self.config.delay_s)
            else:
                import time

                time.sleep(self.config.delay_s)

    @property
    def in_waiting(self):
        self._alive()
        return self._port.in_waiting

    def read(self, size=1):
        """Read up to ``size`` bytes from the wrapped port, then corrupt/drop some.

        A read may first be delayed by ``config.delay_s`` (board time when the
        wrapped port has ``sleep``). Faults apply when ``config.direction`` is
        ``READ`` or ``BOTH``.

        Parameters
        ----------
        size : int
            Bytes to read from the wrapped port (its timeout applies).

        Returns
        -------
        bytes
            What the wrapped port returned after injected faults (possibly
            shorter than ``size``: dropped bytes are not replaced).

        Raises
        ------
        serial.SerialException
            After an injected disconnect (also a :class:`~labkit.exceptions.DeviceError`).
        """
        self._alive()
        self._maybe_delay()
        return self._mangle(self._port.read(size), "read")

    def write(self, data):
        """Write ``data`` to the wrapped port, corrupting/dropping some bytes.

        Once the host has written ``config.disconnect_after`` bytes the bytes up to
        that count are sent and the port disconnects. With probability ``config.duplicate``
        the data is written a second time. Faults apply when
        ``config.direction`` is ``WRITE`` or ``BOTH``; a write may be delayed by
        ``config.delay_s``.

        Parameters
        ----------
        data : bytes-like
            Bytes the host sends.

        Returns
        -------
        int
            ``len(data)`` (what the host believes it wrote, even if bytes were
            dropped on the way).

        Raises
        ------
        serial.SerialException
            On the injected disconnect and on every call after it (also a
            :class:`~labkit.exceptions.DeviceError`).
        """
        self._alive()
        data = bytes(data)
        if self._written + len(data) > self.config.disconnect_after:
            part = int(self.config.disconnect_after - self._written)
            self._port.write(self._mangle(data[:max(part, 0)], "write"))
            self.counts.disconnected = True
            raise _Disconnected("device disconnected (injected fault)")
        self._written += len(data)
        self._maybe_delay()
        self._port.write(self._mangle(data, "write"))
        if self.config.duplicate and self._rng.random() < self.config.duplicate:
            self.counts.duplicated += 1
            self._port.write(self._mangle(data, "write"))
        return len(data)

    def close(self):
        """Close the wrapped port (no fault is injected)."""
        self._port.close()
