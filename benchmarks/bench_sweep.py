"""Parallel efficiency of the studies' machinery: the same 12 flights (6 random worlds × the
static lowest plan and mpc, 200 simulated s each) with 1 and then 2 joblib workers, in one run;
prints flights per minute for each and the efficiency rate(2) / (2 · rate(1)). Not a test.

    python3 benchmarks/bench_sweep.py
"""

import tempfile
import textwrap
import time
from pathlib import Path

from eaplan_drake.studies.sweep import LoadStudy, RunStudy

d = Path(tempfile.mkdtemp())
(d / "eff.yaml").write_text(
    textwrap.dedent("""\
    name: eff
    base: survey
    set: {simulation.time_limit: 200.0}
    uniform: {wind.speed: [0.0, 10.0], wind.direction_deg: [0.0, 360.0]}
    draws: 6
    seed: 3
    policies: [mpc]
    """)
)
st, sd = LoadStudy(d / "eff.yaml")
rates = {}
for jobs in (1, 2):
    t0 = time.perf_counter()
    rows = RunStudy(st, d / f"out{jobs}", directory=sd, n_jobs=jobs, progress=False)
    dt = time.perf_counter() - t0
    rates[jobs] = 60 * len(rows) / dt
    print(f"{jobs} worker(s): {len(rows)} flights in {dt:.1f} s = {rates[jobs]:.1f} flights/min")
print(f"parallel efficiency at 2 workers: {rates[2] / (2 * rates[1]):.2f}")
