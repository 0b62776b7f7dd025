"""Fault runs at the size issues 13 and 27 ask for: >= 10,000 commands through FaultyPort (1 % corrupted
bytes, 0.5 % lost bytes, 1 % duplicated request lines, random disconnects) on ``sim://`` and on the
firmware in simavr.

Prints, per board, one JSON line: the commands issued, damaged requests executed, wrong replies accepted,
unrequested motions left unreported, requests run twice (all must be 0), the faults injected, the wall
time (``seconds``) and ``commands_per_s``. With ``--baseline`` each board also runs with the host's
reply wait of before issue 27 (the full reply timeout after a damaged line, instead of resending once a
longest line's wire time has passed) and a last line prints the speed ratio new / baseline.
Both boards run in lockstep: reply timeouts are board time, so the simulator pays 50 ms of *simulated*
time for a lost reply, not 50 ms of wall time. The CI test
(``tests/arm/test_fault_runs.py``) runs the same function at a few hundred commands.

    python benchmarks/bench_faults.py [--commands N] [--boards sim,simavr] [--max-seconds S] [--baseline]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "arm"))

from test_fault_runs import fault_run  # noqa: E402

import labkit.arm.link._wire as wire  # noqa: E402

BOARDS = {
    "sim": dict(url="sim://?clock=lockstep", timeout=0.01, disconnect_every=10000),
    "simavr": dict(url="simavr://?clock=lockstep", timeout=0.05, disconnect_every=30000),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=10_000)
    ap.add_argument("--boards", default="sim,simavr")
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--max-seconds", type=float, default=None, help="stop a board's run early (reports the count)")
    ap.add_argument("--baseline", action="store_true", help="also run with the reply wait of before issue 27")
    args = ap.parse_args(argv)
    bad = False
    after_bad_line = wire._AFTER_BAD_LINE
    for name in args.boards.split(","):
        cfg = BOARDS[name]
        speed = {}
        for mode in ("new", "baseline") if args.baseline else ("new",):
            wire._AFTER_BAD_LINE = after_bad_line if mode == "new" else math.inf
            r = fault_run(cfg["url"], args.commands, seed=args.seed, disconnect_every=cfg["disconnect_every"],
                          timeout=cfg["timeout"], max_seconds=args.max_seconds)
            r["mode"] = mode
            r["commands_per_s"] = round(r["commands"] / max(r["seconds"], 1e-9), 2)
            speed[mode] = r["commands_per_s"]
            print(json.dumps(r), flush=True)
            bad |= any(r[k] for k in ("damaged_executed", "wrong_replies_accepted", "unreported_motions",
                                      "lost_motions", "run_twice"))
        if args.baseline:
            print(f"{name}: {speed['new']:.2f} commands/s, baseline {speed['baseline']:.2f}: "
                  f"ratio {speed['new'] / speed['baseline']:.2f}", flush=True)
    wire._AFTER_BAD_LINE = after_bad_line
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
