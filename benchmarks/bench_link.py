"""Benchmark of the host link: command round trips and feedback streaming.

Runs against the virtual arm (``sim://``, real-time clock) and, when simavr and
the firmware build are available, the firmware simulator (``simavr://?pace=1``),
and prints each rate beside the wire-time limit at 115200 baud (10 bits per
byte: 11,520 bytes/s), using the bytes actually sent and received.

    python benchmarks/bench_link.py [--quick]

``ratio`` = measured rate / wire-time limit (1.0 would be a link that is
never idle; the virtual arm has no wire, so it can exceed 1).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from labkit.arm import Arm, PortWrapper
from labkit.exceptions import DeviceError

BYTES_PER_S = 115200 / 10


class Counting(PortWrapper):
    """Port wrapper counting bytes in both directions."""

    def __init__(self, port):
        super().__init__(port)
        self.tx = self.rx = 0

    def read(self, n=1):
        data = self._port.read(n)
        self.rx += len(data)
        return data

    def write(self, data):
        self.tx += len(data)
        return self._port.write(data)


def measure(arm, port, label, fn, n):
    tx0, rx0 = port.tx, port.rx
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    dt = time.perf_counter() - t0
    nbytes = (port.tx - tx0) + (port.rx - rx0)
    rate = n / dt
    wire_rate = BYTES_PER_S / (nbytes / n)
    return (label, rate, wire_rate, rate / wire_rate, 1e3 * dt / n)


def bench(url, n):
    import serial

    from labkit.arm.urlhandler import register

    register()
    raw = serial.serial_for_url(url, baudrate=115200, timeout=0.05)
    port = Counting(raw)
    rows = []
    with Arm("arduino_arm_3dof", port, timeout=1.0, check_moves=False) as arm:
        arm.set_host_timeout(0)
        rows.append(measure(arm, port, "PING round trip", arm.ping, n))
        rows.append(measure(arm, port, "STATUS round trip", arm.status, n // 2))
        rows.append(measure(arm, port, "READ round trip", arm.read_adc, n))
        qs = iter(np.radians(np.c_[np.linspace(30, 150, 10 * n), np.full(10 * n, 90.0), np.full(10 * n, 90.0)]))
        rows.append(measure(arm, port, "MOVE round trip", lambda: arm.move_joints(next(qs)), n))
        # streaming at the highest rate the protocol allows: frames per second of board time
        rx0 = port.rx
        df = arm.stream(2.0 if n >= 200 else 1.0, hz=200)
        per_frame = (port.rx - rx0) / max(len(df), 1)
        span = df.attrs["t_stop"] - (df["t"].iloc[0] if len(df) else 0.0)
        rate = len(df) / span if span > 0 else float("nan")
        rows.append(("FB stream @200 Hz", rate, BYTES_PER_S / per_frame, rate / (BYTES_PER_S / per_frame),
                     1e3 / rate, f"lost {df.attrs['lost']} of {df.attrs['expected']} (board-time rate)"))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = ap.parse_args(argv)
    n = 50 if args.quick else 200
    targets = [("virtual arm (sim://, real time)", "sim://?time_scale=1"),
               ("firmware in simavr (simavr://?pace=1)", "simavr://?pace=1")]
    print(f"wire-time limit: 115200 baud, 10 bits/byte = {BYTES_PER_S:.0f} bytes/s\n")
    for name, url in targets:
        try:
            rows = bench(url, n)
        except (DeviceError, OSError) as exc:
            print(f"{name}: not available ({exc})\n")
            continue
        print(name)
        print(f"  {'operation':<20} {'rate /s':>10} {'wire limit /s':>14} {'ratio':>7} {'ms each':>8}")
        for label, rate, wire, ratio, ms, *extra in rows:
            print(f"  {label:<20} {rate:>10.1f} {wire:>14.1f} {ratio:>7.2f} {ms:>8.2f}  {' '.join(extra)}")
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
