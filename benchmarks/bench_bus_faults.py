"""Fault runs of the servo buses at the size issue 41 asks for: the vendor SDK and the virtual bus with a
pseudo-terminal proxy between them that corrupts and drops bytes in both directions.

Prints one JSON line per bus protocol and fault rate: opens and open failures, moves, moves that returned
normally, moves that stopped with a bus fault, ``silent_goal_mismatches`` (moves that returned normally while
a servo's goal register differed from the host's goal: must be 0), ``unexplained`` failures (not a
``DeviceError`` saying what was tried: must be 0), the longest open or move [s] (no hang), the bytes carried,
corrupted and dropped, and the wall time. The labkit on ``PYTHONPATH`` is the one measured, so the same
script measures another checkout (``PYTHONPATH=/path/to/other/checkout``); the proxy and the run are
``tests/arm/bus/test_bus_fault_runs.py``'s.

With ``--gripper`` the arms are the bundled OpenMANIPULATOR-X and SO-101, whose grippers are servos on the bus, and
each arm move is followed by a gripper move to a random position with a random grip limit: the line adds
``gripper_moves``, ``gripper_moves_ok``, ``gripper_faults``, ``gripper_silent_mismatches`` (gripper moves that
returned normally while the servo's goal or limit register differed from what was sent: must be 0) and
``gripper_faults_naming_it`` (a gripper write that did not land: the fault names ``servo N (gripper)``) and
``gripper_faults_unnamed`` (faults naming neither the gripper nor the joint servo that failed: must be 0);
``--gripper-only`` moves the gripper alone (the joints hold), ``--moves`` gripper moves per open.

    python benchmarks/bench_bus_faults.py [--opens N] [--moves M] [--rates 0.01/0.005,0.001/0.0005] [--buses dynamixel,feetech] [--gripper]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "tests" / "arm" / "bus"))

from test_bus_fault_runs import GRIPPER_ROBOTS, bus_fault_run  # noqa: E402

ROBOTS = {"dynamixel": str(HERE / "tests" / "arm" / "bus" / "omx_test.toml"),
          "feetech": str(HERE / "tests" / "arm" / "bus" / "so101_test.toml")}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--opens", type=int, default=20)
    parser.add_argument("--moves", type=int, default=8, help="moves per open")
    parser.add_argument("--rates", default="0.01/0.005,0.001/0.0005", help="corrupt/drop per byte, comma-separated")
    parser.add_argument("--buses", default="dynamixel,feetech")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--latency", type=float, default=20.0, help="the URL's latency [ms]")
    parser.add_argument("--gripper", action="store_true", help="the bundled arms with bus grippers, gripper moves too")
    parser.add_argument("--gripper-only", action="store_true", help="as --gripper, moving the gripper alone")
    args = parser.parse_args(argv)
    import labkit

    for rate in args.rates.split(","):
        corrupt, drop = (float(v) for v in rate.split("/"))
        for bus in args.buses.split(","):
            t0 = time.monotonic()
            gripper = "only" if args.gripper_only else args.gripper
            robot = GRIPPER_ROBOTS[bus] if gripper else ROBOTS[bus]
            counts = bus_fault_run(robot, bus, opens=args.opens, moves_per_open=args.moves, corrupt=corrupt,
                                   drop=drop, seed=args.seed, latency=args.latency, gripper=gripper)
            counts.update(bus=bus, robot=Path(robot).stem, corrupt=corrupt, drop=drop, seconds=round(time.monotonic() - t0, 1),
                          labkit=str(Path(labkit.__file__).parents[1]))
            counts["longest_call_s"] = round(counts["longest_call_s"], 2)
            counts["examples"] = [e[:160] for e in counts["examples"]]
            if "gripper_fault_examples" in counts:
                counts["gripper_fault_examples"] = [e[:200] for e in counts["gripper_fault_examples"]]
            print(json.dumps(counts), flush=True)


if __name__ == "__main__":
    main()
