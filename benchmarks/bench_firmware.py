"""Firmware-in-the-loop acceptance numbers (issues 5 and 13): size, feedback stream, round trip, streaming.

Runs the real firmware binary in simavr (builds it if needed) and prints each measurement with
its target and the ratio. Usage: ``python benchmarks/bench_firmware.py [--quick]``.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

# the measurement functions live with the firmware tests (tests/arm/test_firmware.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from labkit.arm import FirmwareSim, build  # noqa: E402
from tests.arm.test_firmware import (  # noqa: E402
    measure_feedback_stream,
    measure_round_trip,
    measure_segment_stream,
)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs (10 s stream, 1000 segments)")
    args = parser.parse_args(argv)

    log = build(("firmware", "sim"))
    m = re.search(r"flash (\d+) B \(([\d.]+)%.*SRAM (\d+) B \(([\d.]+)%", log + build(("size",)))
    print(f"size     flash {m.group(1)} B = {m.group(2)}% of 32 KB, SRAM {m.group(3)} B = {m.group(4)}% "
          f"of 2 KB (target <= 50%)")

    # simulated speed when free running
    sim = FirmwareSim()
    sim.run()
    t0, w0 = sim.time(), time.perf_counter()
    sim.sleep(20.0)
    speed = (sim.time() - t0) / (time.perf_counter() - w0)
    sim.close()
    print(f"speed    free-running simavr: {speed:.1f}x real time")

    seconds = 10.0 if args.quick else 60.0
    r = measure_feedback_stream(100, seconds)
    print(f"stream   100 Hz x 4 channels for {seconds:.0f} s simulated: {r['frames']} frames "
          f"(expected {r['expected_frames']}), lost {r['lost_frames']}, corrupted {r['corrupted_lines']}, "
          f"wrong values {r['wrong_values']}, wall {r['wall_seconds']:.1f} s")

    # every command of the round-trip acceptance, in board time (lockstep, deterministic: the firmware and the
    # 115200-baud link only) and paced to real time on the wall clock (adds the host's scheduling)
    board = measure_round_trip(5, percentile=100, clock="board")
    wall = measure_round_trip(30)
    for name, v in board.items():
        w = wall[name]
        print(f"rtt      {name:16s} board {v['median_s'] * 1e3:6.2f} ms vs wire {v['wire_s'] * 1e3:6.2f} ms: "
              f"ratio {v['ratio']:.2f} (target <= 1.5); wall clock {w['median_s'] * 1e3:6.2f} ms: ratio {w['ratio']:.2f}")

    n = 1000 if args.quick else 10_000
    r = measure_segment_stream(n, 30)
    print(f"segments {r['segments']} x {r['segment_ms']} ms cubic segments (lockstep host): completed "
          f"{r['completed']}, underruns {r['underruns']}, QFULL retries {r['qfull_retries']}, "
          f"free SRAM low-water {r['mem_free_bytes']} B, simulated {r['sim_seconds']:.1f} s "
          f"(ideal {n * r['segment_ms'] / 1000:.1f} s), wall {r['wall_seconds']:.1f} s")


if __name__ == "__main__":
    main()
