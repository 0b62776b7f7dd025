"""The USB bus adapter: its latency timer, and what to check when status packets do not come back.

A USB serial adapter (FTDI in the U2D2 and most bus boards) holds received bytes until its latency
timer expires, 16 ms by default. The vendor SDKs wait ``2 x latency + 2 ms`` plus the packet's wire
time for a status packet, with their own assumption of the latency (16 ms, or the robot file's
``[bus] latency``, or the URL's ``latency=``): an adapter whose timer is above that makes status packets
arrive after the SDK gave up, the "There is no status packet" / "Incorrect status packet" that
DynamixelSDK users report most. On Linux the timer is
``/sys/bus/usb-serial/devices/<tty>/latency_timer``; :func:`latency_timer` reads it and :func:`advice`
puts it, with the one-line fix, in every message about a silent or damaged bus.

A virtual bus (:class:`labkit.arm.bus.BusEmulator`) is a thread of this process: how soon it answers is
how soon the host's CPU runs it, which on a loaded machine can be seconds, not how a servo behaves (a
servo answers within its return delay, well under a millisecond). A pseudo-terminal that an emulator of
this process serves is :func:`served_by` it, and a driver on it starts each status-packet timeout only
once the emulator has read and answered every byte the host sent (:func:`paced_by`): a status packet the
emulator drops or never sends is still a timeout, one that the host's load delays is not.
"""

from __future__ import annotations

import os
import time
import weakref

__all__ = ["SYSFS", "VIRTUAL_WAIT_LIMIT", "latency_timer", "latency_note", "advice", "serve", "served_by",
           "paced_by"]

#: where Linux shows the USB serial adapters (a test points it at a fake tree)
SYSFS = "/sys"
#: longest wait [s of wall time] for a virtual bus to read what the host sent before a status timeout runs anyway
#: (an emulator whose thread has died, or bytes that never reached it)
VIRTUAL_WAIT_LIMIT = 120.0

_SERVED = weakref.WeakValueDictionary()  # pseudo-terminal -> the BusEmulator of this process serving it


def _sysfs_file(device, sysfs):
    tty = os.path.basename(os.path.realpath(str(device)))
    return tty, os.path.join(sysfs, "bus", "usb-serial", "devices", tty, "latency_timer")


def latency_timer(device, *, sysfs=None):
    """The latency timer [ms] of the USB serial adapter behind ``device``, or ``None`` where none is shown.

    Parameters
    ----------
    device : str
        The adapter's serial device (``/dev/ttyUSB0``, a ``/dev/serial/by-id/...`` link to it).
    sysfs : str, optional
        The sysfs root (default :data:`SYSFS`).

    Returns
    -------
    int or None
        The timer [ms]; ``None`` on another system, for a device that is not a USB serial adapter (a
        pseudo-terminal, an ACM device) or a file that does not hold a number.

    Examples
    --------
    >>> latency_timer("/dev/pts/0") is None
    True
    """
    _, path = _sysfs_file(device, SYSFS if sysfs is None else sysfs)
    try:
        with open(path, "rb") as f:
            text = f.read(16)
        value = int(text.strip())
    except (OSError, ValueError):
        return None
    return value if 0 <= value <= 255 else None


def latency_note(device, timer, assumed):
    """What to do about an adapter latency timer above the latency the status timeouts assume, or ``""``.

    Parameters
    ----------
    device : str
        The adapter's serial device.
    timer : int or None
        Its latency timer [ms] (:func:`latency_timer`).
    assumed : float
        The latency the status-packet timeouts assume [ms].

    Returns
    -------
    str

    Examples
    --------
    >>> latency_note("/dev/ttyUSB0", 16, 1.0).split(": ")[1]
    "set it to 1 ms with 'echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/latency_timer' (or set the robot file's [bus] latency = 16)"
    >>> latency_note("/dev/ttyUSB0", 1, 16.0)
    ''
    """
    if timer is None or timer <= assumed:
        return ""
    tty, _ = _sysfs_file(device, SYSFS)
    return (f"the adapter {tty} holds received bytes for {timer} ms (its USB latency timer), longer than the "
            f"{assumed:g} ms the status timeouts allow for: set it to 1 ms with "
            f"'echo 1 | sudo tee /sys/bus/usb-serial/devices/{tty}/latency_timer' (or set the robot file's "
            f"[bus] latency = {timer})")


def advice(driver):
    """What to check when status packets are lost or damaged on ``driver``'s bus.

    Parameters
    ----------
    driver : BusDriver
        The open bus (its ``baudrate``, ``device``, ``latency`` and ``latency_timer``).

    Returns
    -------
    str
    """
    timer = getattr(driver, "latency_timer", None)
    note = latency_note(driver.device, timer, driver.latency)
    shown = f"{timer} ms" if timer is not None else "not shown by this system"
    return (f"tried at {driver.baudrate} bit/s, status timeouts for {driver.latency:g} ms of adapter latency, "
            f"adapter latency timer {shown}; "
            + (note + "; otherwise " if note else "")
            + f"check the cable and its connectors, that every servo is set to {driver.baudrate} bit/s and "
              f"powered, and that no other program has the port open")


def serve(path, emulator):
    """Record that ``emulator`` (a :class:`BusEmulator` of this process) serves pseudo-terminal ``path``
    (``emulator=None``: no longer).

    Parameters
    ----------
    path : str
    emulator : BusEmulator or None
    """
    key = os.path.realpath(path)
    if emulator is None:
        _SERVED.pop(key, None)
    else:
        _SERVED[key] = emulator


def served_by(device):
    """The :class:`BusEmulator` of this process that serves ``device``, or ``None`` (a real adapter).

    Parameters
    ----------
    device : str

    Returns
    -------
    BusEmulator or None

    Examples
    --------
    >>> served_by("/dev/ttyUSB0") is None
    True
    """
    return _SERVED.get(os.path.realpath(str(device)))


def paced_by(port_class, emulator):
    """The SDK's ``PortHandler`` whose status timeouts start once ``emulator`` has handled every byte sent.

    ``emulator.handled`` counts the bytes its thread has read and answered; the port counts the bytes it
    wrote. While the first is behind, no time has passed for the virtual servos and the timeout's clock is
    held at its start (at most :data:`VIRTUAL_WAIT_LIMIT` s); then the usual timeout (``2 x latency + 2 ms``
    plus the packet's wire time) runs, as on a real bus from the moment a servo has the request.

    Parameters
    ----------
    port_class : type
        The SDK's ``PortHandler`` (or a subclass).
    emulator : BusEmulator

    Returns
    -------
    type
    """

    class Port(port_class):
        def openPort(self):
            self.sent = 0
            self.base = emulator.handled  # bytes an earlier host sent this bus
            self.behind_since = None
            return super().openPort()

        def writePort(self, packet):
            written = super().writePort(packet)
            self.sent += written or 0
            return written

        def isPacketTimeout(self):
            now = time.monotonic()
            if emulator.handled - self.base < self.sent and emulator.serving:
                self.behind_since = self.behind_since or now
                if now - self.behind_since < VIRTUAL_WAIT_LIMIT:
                    self.packet_start_time = self.getCurrentTime()  # the servos have not got the request yet
                    return False
            self.behind_since = None
            return super().isPacketTimeout()

    return Port
