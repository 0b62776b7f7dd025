"""Run the real labkit arm firmware in the simavr AVR simulator (firmware in the loop).

:class:`FirmwareSim` builds the firmware and the harness (``firmware/sim/labkit_sim.c``) if
needed, launches the harness, and exposes what a test or a physics model needs: the pty that
stands for the Uno's USB serial port, the servo pulse widths the firmware really produces
(measured on the pins, in simulated time), analog input voltages, hold/run/reset, pacing of
simulated time to the wall clock, and a per-tick hook that closes the loop with a Python model
of the arm (``labkit.arm``).

Simulated time runs in one of three ways:

* free (``pace=0``, the default of :class:`FirmwareSim`): as fast as the simulator goes, about
  10x real time, whatever the host does;
* paced (``pace=f > 0``): ``f`` x wall-clock time, like a real board when ``f = 1``;
* stepped (:meth:`FirmwareSim.set_stepped`, what :meth:`FirmwareSim.open_port` and ``simavr://``
  use by default): the CPU runs only while the host waits (:meth:`FirmwareSim.advance`,
  :meth:`FirmwareSim.sleep`, a read of the port), so the host lives in board time and a loaded
  machine never changes what happens in it.

The protocol spoken over the pty is ``docs/protocol.md``; ``serial.serial_for_url("simavr://")``
(see :mod:`labkit.arm.urlhandler.protocol_simavr`) or :meth:`FirmwareSim.open_port` gives a ready
pyserial port whose waits run in board time.
"""

from __future__ import annotations

import atexit
import collections
import fcntl
import os
import queue
import subprocess
import threading
import time
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

from labkit.exceptions import DeviceError, OptionError

__all__ = ["FIRMWARE_DIR", "FirmwareSim", "PulseEvent", "build", "default_elf", "harness_path"]

FIRMWARE_DIR = Path(os.environ.get("LABKIT_FIRMWARE_DIR", Path(__file__).resolve().parents[3] / "firmware"))
"""Folder of the firmware sources and its Makefile (override with ``LABKIT_FIRMWARE_DIR``)."""

VOLTS_MAX = 5.5
TickHook = Callable[[float, dict], "Mapping[int, float] | None"]


@dataclass(frozen=True)
class PulseEvent:
    """One servo pulse whose width differs from the previous pulse of its channel.

    Attributes
    ----------
    t : float
        Simulated time of the falling edge [s] since power-on.
    channel : int
        Servo channel (pin D(2+channel)).
    width_us : float
        Pulse width [us].
    """

    t: float
    channel: int
    width_us: float


def default_elf(firmware_dir=None):
    """Path of the firmware ELF that ``make -C firmware`` builds.

    Parameters
    ----------
    firmware_dir : str or os.PathLike, optional
        Firmware source directory; default ``FIRMWARE_DIR`` (``$LABKIT_FIRMWARE_DIR``
        or the repository's ``firmware/``).

    Returns
    -------
    pathlib.Path
        ``<firmware_dir>/build/labkit_arm.elf`` (not checked for existence).
    """
    return Path(firmware_dir or FIRMWARE_DIR) / "build" / "labkit_arm.elf"


def harness_path(firmware_dir=None):
    """Path of the simavr harness executable that ``make -C firmware sim`` builds.

    Parameters
    ----------
    firmware_dir : str or os.PathLike, optional
        Firmware source directory; default ``FIRMWARE_DIR`` (``$LABKIT_FIRMWARE_DIR``
        or the repository's ``firmware/``).

    Returns
    -------
    pathlib.Path
        ``<firmware_dir>/build/labkit_sim`` (not checked for existence).
    """
    return Path(firmware_dir or FIRMWARE_DIR) / "build" / "labkit_sim"


def build(targets=("firmware", "sim"), firmware_dir=None, *, quiet=True):
    """Build firmware and harness with make (no-op when up to date; safe across processes).

    Parameters
    ----------
    targets : sequence of str
        Makefile targets: ``"firmware"``, ``"sim"``, ``"tests"``.
    firmware_dir : path-like, optional
        Defaults to :data:`FIRMWARE_DIR`.
    quiet : bool
        Capture make's output (it is shown in the error on failure).

    Returns
    -------
    str
        make's output (includes the flash/SRAM line of ``avr-size``).

    Raises
    ------
    DeviceError
        If make fails or the folder is missing.
    """
    fdir = Path(firmware_dir or FIRMWARE_DIR)
    if not (fdir / "Makefile").exists():
        raise DeviceError(f"expected the firmware sources with a Makefile in {fdir}, found none")
    (fdir / "build").mkdir(exist_ok=True)
    with open(fdir / "build" / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # pytest-xdist workers build one at a time
        proc = subprocess.run(["make", "-C", str(fdir), *targets], capture_output=True, text=True)
    if proc.returncode != 0:
        raise DeviceError(f"building {targets} in {fdir} failed:\n{proc.stdout}\n{proc.stderr}")
    if not quiet:
        print(proc.stdout)
    return proc.stdout


class FirmwareSim:
    """The compiled firmware running in simavr, with its UART on a pty.

    Parameters
    ----------
    elf : path-like, optional
        Firmware ELF; default: the one built from ``firmware/`` (built if needed).
    pace : float
        0 runs free (about 10x real time); ``f > 0`` keeps simulated time at ``f`` x wall time.
        Ignored while stepped (:meth:`set_stepped`).
    on_tick : callable, optional
        ``on_tick(sim_time_s, pulses_us) -> {analog_pin: volts} | None``, called every
        ``tick_period`` [s] of simulated time while the CPU is paused; the returned voltages
        are applied before it continues. Without a hook, analog pins keep the voltages last set
        with :meth:`set_analog`.
    tick_period : float
        Hook period [s] of simulated time.
    build_if_needed : bool
        Run make first (a no-op when up to date).

    The CPU starts **held** (so that a host can open the pty first; pyserial flushes input on
    open); call :meth:`run`. Use as a context manager or call :meth:`close`.

    Example
    -------
    >>> import serial
    >>> with FirmwareSim() as sim:                       # doctest: +SKIP
    ...     port = serial.Serial(sim.port, 115200, timeout=1)
    ...     sim.run()                                     # free running: the host waits on the wall clock
    ...     port.readline()                               # b'READY labkit-arm 3 ...'
    ...     port.write(b"#1 MOVE 4500 9000 9000 *354E\\n"); port.readline()
    ...     sim.sleep(0.1); sim.pulses()[0]               # 1000.0 us
    >>> with FirmwareSim() as sim:                       # doctest: +SKIP
    ...     port = sim.open_port(timeout=1)               # stepped: reads wait in simulated time
    ...     port.readline(), port.board_time              # (b'READY labkit-arm 3 ...', 0.0088)
    """

    def __init__(self, elf=None, *, pace=0.0, on_tick: TickHook | None = None, tick_period=0.005,
                 build_if_needed=True, log_size=500_000):
        if pace < 0:
            raise OptionError(f"expected pace >= 0 (0 = free running), got {pace}")
        if tick_period <= 0:
            raise OptionError(f"expected tick_period > 0 s, got {tick_period}")
        if build_if_needed:
            build(("firmware", "sim") if elf is None else ("sim",))
        self.elf = Path(elf) if elf is not None else default_elf()
        if not self.elf.exists():
            raise DeviceError(f"firmware ELF {self.elf} does not exist")
        self.on_tick = on_tick
        self.tick_period = float(tick_period)
        self._widths: dict[int, float] = {}
        self.pulse_log: collections.deque[PulseEvent] = collections.deque(maxlen=log_size)
        self._replies: queue.Queue[str] = queue.Queue()
        self._events: queue.Queue[str] = queue.Queue()
        self._lock = threading.Lock()
        self._state_lock = threading.Lock()
        self.crashed: str | None = None
        self.hook_error: Exception | None = None
        """First exception raised by ``on_tick`` (re-raised by the next command)."""
        self.running = False
        self.pace = float(pace)
        """Ratio of simulated to wall-clock time [-] (0: free running; unused while stepped)."""
        self.stepped = False
        """Whether the CPU runs only inside :meth:`advance` (see :meth:`set_stepped`)."""
        self.board_time = 0.0
        """Simulated time [s] at the last :meth:`advance`, :meth:`sleep`, :meth:`time` or :meth:`hold`
        (exact while stepped and running only in :meth:`advance`)."""
        self.host_bytes = 0
        """Bytes the host has written into :attr:`port` (counted by the port of :meth:`open_port`)."""
        self.board_bytes = 0
        """Bytes the harness had written into :attr:`port` at the end of the last :meth:`advance`."""
        self._proc = subprocess.Popen(
            [str(harness_path()), str(self.elf), "--pace", str(float(pace))],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True, bufsize=1,
        )
        first = self._proc.stdout.readline().split()
        ready = self._proc.stdout.readline().split()
        if len(first) != 2 or first[0] != "PTY" or not ready or ready[0] != "READY":
            self._proc.kill()
            raise DeviceError(f"simavr harness did not start: got {first!r} {ready!r}")
        self.port = first[1]
        """Path of the pty connected to the simulated UART0."""
        self._reader = threading.Thread(target=self._read_loop, name="labkit-simavr", daemon=True)
        self._reader.start()
        _LIVE.add(self)
        if on_tick is not None:
            self._command(f"tick {self.tick_period * 1e6:.3f}", "OK")

    # ---------------------------------------------------------------- harness I/O
    def _read_loop(self):
        try:
            self._read_lines()
        except (ValueError, OSError):  # stdout closed during shutdown
            pass
        finally:
            self._events.put("EXIT")
            self._replies.put("EXIT")

    def _read_lines(self):
        for line in self._proc.stdout:
            parts = line.split()
            if not parts:
                continue
            kind = parts[0]
            if kind == "P":
                ev = PulseEvent(float(parts[2]) * 1e-6, int(parts[1]), float(parts[3]))
                with self._state_lock:
                    self._widths[ev.channel] = ev.width_us
                    self.pulse_log.append(ev)
            elif kind == "TICK":
                self._tick(float(parts[1]) * 1e-6, [float(w) for w in parts[2:]])
            elif kind == "WOKE":
                self._events.put(line.strip())
            elif kind == "CRASH":
                self.crashed = line.strip()
                self._events.put(line.strip())
            else:
                self._replies.put(line.strip())

    def _tick(self, t, widths):
        pulses = {c: w for c, w in enumerate(widths) if w > 0}
        cmds = []
        try:
            volts = self.on_tick(t, pulses) if self.on_tick else None
            cmds = [self._adc_cmd(pin, v) for pin, v in (volts or {}).items()]
        except Exception as exc:  # noqa: BLE001 - reported to the caller by the next command
            if self.hook_error is None:
                self.hook_error = exc
        self._send("\n".join(cmds + ["go"]))

    @staticmethod
    def _adc_cmd(pin, volts):
        pin = int(pin)
        if not 0 <= pin <= 5:
            raise OptionError(f"expected an analog pin 0..5, got {pin}")
        if not 0.0 <= volts <= VOLTS_MAX:
            raise OptionError(f"expected 0..{VOLTS_MAX} V on analog pin {pin}, got {volts}")
        return f"adc {pin} {round(volts * 1000)}"

    def _send(self, text):
        if self._proc.poll() is not None:
            raise DeviceError("the simavr harness has exited")
        try:
            self._proc.stdin.write(text + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, ValueError) as exc:
            raise DeviceError(f"the simavr harness is gone: {exc}") from exc

    def _command(self, text, expect, timeout=10.0):
        if self.hook_error is not None:
            exc, self.hook_error = self.hook_error, None
            raise DeviceError(f"the on_tick hook failed: {exc!r}") from exc
        with self._lock:
            self._send(text)
            try:
                reply = self._replies.get(timeout=timeout)
            except queue.Empty:
                raise DeviceError(f"simavr harness did not answer {text!r} within {timeout} s") from None
        if not reply.startswith(expect):
            raise DeviceError(f"simavr harness: expected {expect!r} for {text!r}, got {reply!r}")
        return reply

    # ---------------------------------------------------------------- control
    def run(self):
        """Let the simulated CPU run (after the host opened :attr:`port`)."""
        self._command("run", "OK run")
        self.running = True

    def hold(self):
        """Pause the simulated CPU; returns the simulated time [s].

        Returns
        -------
        float
            Simulated time since power-on [s] at which the CPU was held.
        """
        reply = self._command("hold", "OK hold")
        self.running = False
        self.board_time = float(reply.split()[2]) * 1e-6
        return self.board_time

    def reset(self):
        """Reset the MCU (like the Uno's auto-reset when a port opens); EEPROM is kept."""
        self._command("reset", "OK reset")
        with self._state_lock:
            self._widths.clear()

    def set_lockstep(self, on=True):
        """Hold the CPU after each OK/ERR reply until the host sends bytes or calls :meth:`sleep`.

        Simulated time then excludes the host's own reaction time (an ideal host); wire time and
        firmware time are still simulated exactly. Useful to measure the firmware, not the PC.
        Between a host's bytes and the next reply the CPU runs free; :meth:`set_stepped` (the
        ``clock=lockstep`` of ``simavr://``) instead runs it only while the host waits.

        Parameters
        ----------
        on : bool
            Switch lockstep on (True) or off (False).
        """
        self._command(f"lockstep {int(bool(on))}", "OK lockstep")

    def set_stepped(self, on=True):
        """Run the CPU only inside :meth:`advance` (and :meth:`sleep`): simulated time follows the host.

        With stepping on, simulated time stands still while the host computes, is descheduled or
        sleeps on the wall clock; it advances only by the amounts the host asks for. The firmware
        then sees the same request bytes at the same simulated times on an idle and on a loaded
        machine, so its timers (the host-silence timeout, stream rates) are deterministic. Pacing
        and :meth:`set_lockstep` do not apply while stepped.

        Parameters
        ----------
        on : bool
            Switch stepping on (True) or back to free/paced running (False).
        """
        self._command(f"stepped {int(bool(on))}", "OK stepped")
        self.stepped = bool(on)

    def advance(self, seconds, *, until_line=False, timeout=None):
        """Let the CPU run for ``seconds`` of simulated time (stepped mode), then hold it.

        The host's bytes written so far (:attr:`host_bytes`) reach the UART first; the board's
        output is written to :attr:`port` before this returns (:attr:`board_bytes` counts it).

        Parameters
        ----------
        seconds : float
            Longest simulated time to run [s], ``>= 0``.
        until_line : bool
            Stop as soon as the board completed an output line (its ``LF``), even earlier.
        timeout : float, optional
            Wall-clock limit [s]; default ``30 + 20 * seconds``.

        Returns
        -------
        float
            Simulated time [s] when the CPU was held again.

        Raises
        ------
        DeviceError
            Not stepped or not running, the host's bytes did not reach the simulator, or the
            simulated CPU stopped.
        OptionError
            ``seconds`` negative or not finite.
        """
        seconds = float(seconds)
        if not 0.0 <= seconds < float("inf"):
            raise OptionError(f"expected seconds >= 0 of simulated time, got {seconds}")
        if not (self.stepped and self.running):
            raise DeviceError("advance() needs a stepped, running simulator: call set_stepped() and run()")
        limit = timeout if timeout is not None else 30.0 + 20.0 * seconds
        reply = self._command(f"advance {seconds * 1e6:.3f} {self.host_bytes} {int(bool(until_line))}", "HELD",
                              timeout=limit)
        _, t_us, sent = reply.split()
        self.board_time = float(t_us) * 1e-6
        self.board_bytes = int(sent)
        return self.board_time

    def open_port(self, *, clock="lockstep", **serial_options):
        """Open :attr:`port` as a pyserial port whose reads wait in board time, then run the CPU.

        Parameters
        ----------
        clock : {"lockstep", "realtime"}
            ``"lockstep"`` steps the simulator (:meth:`set_stepped`): simulated time runs only
            while the host waits on the port; ``"realtime"`` leaves it free or paced.
        **serial_options
            ``baudrate``, ``timeout`` [s of board time] ... of :class:`serial.Serial`.

        Returns
        -------
        labkit.arm.SimavrPort
            The open port (``port.sim`` is this simulator).

        Raises
        ------
        DeviceError
            The CPU already runs (open the port before :meth:`run`: pyserial flushes input on open).
        OptionError
            An unknown ``clock``.
        """
        from labkit.arm.simavr._simavr_port import SimavrPort

        if self.running:
            raise DeviceError("open the simulator's port before run(): the CPU already runs")
        port = SimavrPort(self, clock=clock, **serial_options)
        self.run()
        return port

    def set_pace(self, factor):
        """0: free running; ``factor > 0``: simulated time runs ``factor`` x wall time.

        Parameters
        ----------
        factor : float
            Ratio of simulated to wall-clock time [-], ``>= 0`` (0: as fast as possible).

        Raises
        ------
        ValueError
            ``factor`` is negative.
        """
        if factor < 0:
            raise OptionError(f"expected pace >= 0, got {factor}")
        self._command(f"pace {float(factor)}", "OK pace")
        self.pace = float(factor)

    def set_analog(self, pin, volts):
        """Set the voltage [V] (0..5.5) on analog input ``pin`` (0..5; A5 = user pot).

        Parameters
        ----------
        pin : int
            Analog input number, 0..5.
        volts : float
            Voltage [V], 0..5.5.

        Raises
        ------
        ValueError
            ``pin`` or ``volts`` out of range.
        """
        self._send(self._adc_cmd(pin, float(volts)))

    def time(self):
        """Simulated time [s] since power-on. Also a barrier: earlier pulse reports are in.

        Returns
        -------
        float
            Simulated time [s].
        """
        self.board_time = float(self._command("time", "TIME").split()[1]) * 1e-6
        return self.board_time

    def pulses(self, sync=True):
        """Latest pulse width [us] per servo channel that has produced pulses.

        Parameters
        ----------
        sync : bool
            First call :meth:`time` so that every pulse report up to now is in.

        Returns
        -------
        dict of int to float
            ``{channel: width_us}``.
        """
        if sync:
            self.time()
        with self._state_lock:
            return dict(self._widths)

    def pulse_events(self, since=0.0):
        """Pulse-width changes (:class:`PulseEvent`) at simulated time >= ``since`` [s].

        Parameters
        ----------
        since : float
            Earliest simulated time to include [s].

        Returns
        -------
        list of PulseEvent
            In the order they were reported.
        """
        with self._state_lock:
            return [e for e in self.pulse_log if e.t >= since]

    def sleep(self, seconds, timeout=None):
        """Block until ``seconds`` of simulated time have passed (the CPU must be running).

        Stepped (:meth:`set_stepped`), this is :meth:`advance` for ``seconds``.

        Parameters
        ----------
        seconds : float
            Simulated time to let pass [s].
        timeout : float, optional
            Wall-clock limit [s]; default ``30 + 5 * seconds``.

        Returns
        -------
        float
            Simulated time [s] at wake-up.

        Raises
        ------
        DeviceError
            The CPU is held, simulated time did not advance within ``timeout``, or
            the simulated CPU crashed or exited.
        """
        if not self.running:
            raise DeviceError("the simulated CPU is held: call run() before sleep()")
        if self.stepped:
            return self.advance(seconds, timeout=timeout)
        while not self._events.empty():
            self._events.get_nowait()
        self._command(f"sleep {seconds * 1e6:.3f}", "OK sleep")
        limit = timeout if timeout is not None else 30.0 + 5.0 * seconds
        t_end = time.monotonic() + limit
        while True:
            try:
                ev = self._events.get(timeout=max(0.0, t_end - time.monotonic()))
            except queue.Empty:
                raise DeviceError(f"simulated time did not advance by {seconds} s within {limit} s") from None
            if ev.startswith("WOKE"):
                self.board_time = float(ev.split()[1]) * 1e-6
                return self.board_time
            if ev.startswith(("CRASH", "EXIT")):
                raise DeviceError(f"simulated CPU stopped: {ev}")

    def close(self):
        """Stop the harness (kills it; simavr's uart_pty_stop can hang)."""
        if self._proc.poll() is None:
            try:
                self._send("quit")
                self._proc.wait(timeout=2)
            except (DeviceError, subprocess.TimeoutExpired):
                self._proc.kill()
                self._proc.wait()
        self._reader.join(timeout=2)
        for f in (self._proc.stdin, self._proc.stdout):
            try:
                f.close()
            except (OSError, ValueError):  # best effort at shutdown
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        proc = getattr(self, "_proc", None)
        if proc is not None and proc.poll() is None:
            proc.kill()


#: every FirmwareSim not yet garbage collected: closed at interpreter exit, before the daemon reader threads
#: are frozen in the middle of a read of the harness's pipe (which aborted the interpreter: "Fatal Python
#: error: _enter_buffered_busy", exit status -6, when a simavr:// port was left open)
_LIVE = weakref.WeakSet()


@atexit.register
def _close_all():
    for sim in list(_LIVE):
        try:
            sim.close()
        except Exception:  # noqa: BLE001 - best effort at exit
            pass
