"""Benchmark of a class's grading: submissions per minute on the local pool and on dask.distributed.

Assigns the tiny tagged lab of ``tests/course/course_lab.py`` (one notebook, one
solution cell, one public and two hidden checks), writes N simulated submissions
(half correct, half partly wrong), and grades them twice in the same run:

* the local pool (``labkit grade --jobs 2``: two worker processes);
* a dask.distributed ``LocalCluster``: a real scheduler and two single-threaded
  worker processes talking TCP on 127.0.0.1 (what ``--scheduler tcp://...`` uses).

Every submission runs in its own sandboxed kernel (allow-list bubblewrap + prlimit + the
memory watchdog), then its checks run in a clean sandboxed checker process, so the figures
include both start-ups, the sandbox, the feedback page and the batch's one grading of the
untouched student version (free rows). It prints submissions/min for both engines and their
ratio, and checks every score.

    python benchmarks/bench_grading.py [-n 300] [--no-html]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from labkit.course import Limits, assign, grade  # noqa: E402
from tests.course import course_lab as cl  # noqa: E402


def run(engine, subs, lab, out, n, html, scheduler=None):
    t0 = time.perf_counter()
    results = grade(subs, lab, out, limits=Limits(cpu_seconds=30, memory_bytes=2 * 2**30, wall_seconds=120),
                    scheduler=scheduler, jobs=2, html=html, progress=True)
    wall = time.perf_counter() - t0
    bad = [r.student for r in results if r.points != (4 if int(r.student[1:]) % 2 == 0 else 2)]
    assert len(results) == n and not bad, f"{engine}: wrong scores for {bad[:5]}"
    rate = 60 * n / wall
    print(f"{engine:<34} {n:>4} submissions in {wall:7.1f} s  ->  {rate:6.1f} submissions/min "
          f"({wall / n:.2f} s each)", flush=True)
    return rate


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=300, help="number of submissions (default 300)")
    ap.add_argument("--no-html", action="store_true", help="skip the feedback pages")
    args = ap.parse_args(argv)
    from distributed import LocalCluster

    with tempfile.TemporaryDirectory(prefix="labkit-bench-grading-") as tmp:
        tmp = Path(tmp)
        lab = cl.write_lab(tmp / "lab")
        assign(lab, tmp / "student")
        subs = tmp / "submissions"
        for i in range(args.n):
            code = cl.SOLUTION if i % 2 == 0 else cl.SUBMISSIONS["partly_wrong"]
            cl.write_submission(tmp / "student", subs / f"s{i:03d}", code)
        print(f"{args.n} submissions, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}", flush=True)
        local = run("local pool (2 processes)", subs, lab, tmp / "fb_local", args.n, not args.no_html)
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", protocol="tcp",
                          dashboard_address=None) as cluster:
            dask = run(f"dask ({cluster.scheduler_address}, 2 workers)", subs, lab, tmp / "fb_dask", args.n,
                       not args.no_html, scheduler=cluster.scheduler_address)
        print(f"ratio dask / local pool: {dask / local:.2f}; load average now {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
