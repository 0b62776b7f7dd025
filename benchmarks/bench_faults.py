"""Fault runs at the size issues 13 and 27 ask for: >= 10,000 commands through FaultyPort (1 % corrupted
bytes, 0.5 % lost bytes, 1 % duplicated request lines, random disconnects) on ``sim://`` and on the
firmware in simavr.

Prints, per board and mode, one JSON line: the commands issued, damaged requests executed, wrong replies
accepted, unrequested motions left unreported, requests run twice (all must be 0), the faults injected, the
wall time (``seconds``), ``commands_per_s``, and the simulated time the run took (``board_seconds``,
``board_ms_per_command``: the same on every machine, lockstep runs being a function of their seed).
Modes: ``new`` (what the link does); with ``--compare`` also ``timeout``, the lockstep reply waits of
before (every lost reply waited the full reply timeout, or a longest line's wire time after a damaged
line, instead of giving up once no reply has begun within the request's wire time plus the board's reply
time); with ``--baseline`` also ``baseline``, the wait of before issue 27 (the full reply timeout even
after a damaged line). A last line per board prints the speed ratios against ``new``.
Both boards run in lockstep: reply timeouts are board time, so the simulator pays 50 ms of *simulated*
time for a lost reply, not 50 ms of wall time, and the simulator's speed (wall seconds per simulated
second, which depends on the machine's load) multiplies whatever board time the link spends. The CI test
(``tests/arm/test_fault_runs.py``) runs the same function at a few hundred commands.

    python benchmarks/bench_faults.py [--commands N] [--boards sim,simavr] [--max-seconds S] [--compare] [--baseline]
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
    "sim": dict(url="sim://arduino_arm_3dof?clock=lockstep", timeout=0.01, disconnect_every=10000),
    "simavr": dict(url="simavr://?clock=lockstep", timeout=0.05, disconnect_every=30000),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=10_000)
    ap.add_argument("--boards", default="sim,simavr")
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--max-seconds", type=float, default=None, help="stop a board's run early (reports the count)")
    ap.add_argument("--compare", action="store_true", help="also run with the lockstep reply waits of before")
    ap.add_argument("--baseline", action="store_true", help="also run with the reply wait of before issue 27")
    args = ap.parse_args(argv)
    bad = False
    saved = wire._AFTER_BAD_LINE, wire.Wire.reply_wait, wire.Wire.reply_quiet
    modes = ["new"] + ["timeout"] * args.compare + ["baseline"] * args.baseline
    for name in args.boards.split(","):
        cfg = BOARDS[name]
        speed = {}
        for mode in modes:
            wire._AFTER_BAD_LINE, wire.Wire.reply_wait, wire.Wire.reply_quiet = saved
            if mode != "new":  # the full reply timeout on lockstep ports too, and no early end of a silent wait
                wire.Wire.reply_wait = lambda self, command, request_bytes: self.timeout
                wire.Wire.reply_quiet = lambda self, command, request_bytes: None
            if mode == "baseline":
                wire._AFTER_BAD_LINE = math.inf
            r = fault_run(cfg["url"], args.commands, seed=args.seed, disconnect_every=cfg["disconnect_every"],
                          timeout=cfg["timeout"], max_seconds=args.max_seconds)
            r["mode"] = mode
            r["commands_per_s"] = round(r["commands"] / max(r["seconds"], 1e-9), 2)
            r["board_ms_per_command"] = round(1e3 * r["board_seconds"] / max(r["commands"], 1), 1)
            speed[mode] = r
            print(json.dumps(r), flush=True)
            bad |= any(r[k] for k in ("damaged_executed", "wrong_replies_accepted", "unreported_motions",
                                      "lost_motions", "run_twice"))
        new = speed["new"]
        for mode in modes[1:]:
            old = speed[mode]
            print(f"{name}: new {new['commands_per_s']:.2f} commands/s ({new['board_ms_per_command']:.0f} ms of board "
                  f"time each), {mode} {old['commands_per_s']:.2f} ({old['board_ms_per_command']:.0f} ms): wall ratio "
                  f"{new['commands_per_s'] / old['commands_per_s']:.2f}, board-time ratio "
                  f"{old['board_ms_per_command'] / new['board_ms_per_command']:.2f}", flush=True)
    wire._AFTER_BAD_LINE, wire.Wire.reply_wait, wire.Wire.reply_quiet = saved
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
