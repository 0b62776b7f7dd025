"""Fault runs at the size issue 13 asks for: >= 10,000 commands through FaultyPort (1 % corrupted bytes,
0.5 % lost bytes, random disconnects) on ``sim://`` and on the firmware in simavr.

Prints, per board, one JSON line: the commands issued, damaged requests executed, wrong replies accepted,
unrequested motions left unreported (all must be 0), the faults injected and the wall time (``seconds``).
Both boards run in lockstep: reply timeouts are board time, so the simulator pays 50 ms of *simulated*
time for a lost reply, not 50 ms of wall time. The CI test
(``tests/arm/test_fault_runs.py``) runs the same function at a few hundred commands.

    python benchmarks/bench_faults.py [--commands N] [--boards sim,simavr] [--max-seconds S]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "arm"))

from test_fault_runs import fault_run  # noqa: E402

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
    args = ap.parse_args(argv)
    bad = False
    for name in args.boards.split(","):
        cfg = BOARDS[name]
        r = fault_run(cfg["url"], args.commands, seed=args.seed, disconnect_every=cfg["disconnect_every"],
                      timeout=cfg["timeout"], max_seconds=args.max_seconds)
        print(json.dumps(r), flush=True)
        bad |= any(r[k] for k in ("damaged_executed", "wrong_replies_accepted", "unreported_motions", "lost_motions"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
