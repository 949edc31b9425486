"""`scripts/bench scaling --simulate PLATFORM --against-real ROUNDS`: the simulation checked
against what this machine can measure.

The weak system of the first --per-rank on 1 and 2 ranks (2 only where this machine has two
cores), run for real (build/hardrod, one thread per rank, ranks bound to cores) and simulated
(build-smpi/hardrod under smpirun) in turns, ROUNDS times each: per pair the ratio of the
simulated to the real time per production step, and their median; both must end in one state.
The tolerance the harness states is what the ratios show on this machine, not an assumption.
"""

import json
import statistics
import subprocess
import time

from . import mpi
from .common import HARDROD, NPROC, g, markdown_table

# A round's ratio farther from 1 than this fails the check (this machine's drift within the
# hour is up to 1.5x; the compute of a simulated rank runs in a library smpirun loads).
TOLERANCE = 0.35


def _run(argv, env, out):
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "run.log", "w") as log:
        rc = subprocess.run(argv, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=out).returncode
    summary = out / "summary.json"
    if rc != 0 or not summary.exists():
        return None
    return json.loads(summary.read_text())


def check(args, out, platform, hosts, sim):
    """Rows {ranks, real_us, simulated_us, ratios, ratio_median, same_state} and the verdict.
    `sim` is the simulate module (its argument lists and environment)."""
    size = int(str(args.per_rank).split(",")[0])
    rows, ok = [], True
    for ranks in [r for r in (1, 2) if r <= NPROC]:
        _, sets, grid = sim.system_sets("weak", size, ranks)
        sets = sim.run_sets(args, sets)
        real_env = {**mpi.environment(shared_cores=False), "OMP_NUM_THREADS": "1"}
        real, simulated, sums = [], [], set()
        for k in range(args.against_real):
            for kind in ("real", "simulated") if k % 2 == 0 else ("simulated", "real"):
                run_out = out / "against-real" / f"{ranks}-{kind}-{k}"
                if kind == "real":
                    argv = mpi.prefix(ranks, bind=True) + sim.hardrod_argv(HARDROD, sets, grid, run_out)
                    env = real_env
                else:
                    argv, env = sim.smpirun_argv(args, platform, hosts, ranks, sets, grid, run_out), sim.simulated_env(args)
                start = time.time()
                s = _run(argv, env, run_out)
                if s is None:
                    ok = False
                    print(f"    against real: {ranks} rank(s), {kind}: failed (see {run_out}/run.log)")
                    continue
                times = real if kind == "real" else simulated
                times.append(1e6 * s["production_seconds_per_step"])
                sums.add(s["state_checksum"])
                print(f"    against real: {ranks} rank(s), {kind}: {g(times[-1], 4)} us per step "
                      f"({time.time() - start:.0f} s)", flush=True)
        ratios = [s / r for s, r in zip(simulated, real)]
        median = statistics.median(ratios) if ratios else None
        row_ok = median is not None and abs(median - 1.0) <= TOLERANCE and len(sums) == 1
        ok = ok and row_ok
        rows.append({"ranks": ranks, "real_us": real, "simulated_us": simulated, "ratios": ratios,
                     "ratio_median": median, "same_state": len(sums) == 1, "checksums": sorted(sums),
                     "within_tolerance": row_ok})
    return rows, ok


def table(rows):
    return markdown_table(
        ["ranks", "real us per step", "simulated us per step", "simulated / real (median, range)", "one state"],
        [[r["ranks"], ", ".join(g(x, 3) for x in r["real_us"]), ", ".join(g(x, 3) for x in r["simulated_us"]),
          f"{g(r['ratio_median'], 3)} ({g(min(r['ratios']), 3)}-{g(max(r['ratios']), 3)})" if r["ratios"] else "-",
          "yes" if r["same_state"] else "NO"] for r in rows])


def note(rows, ok):
    return (f"Against real runs on this machine, in turns: simulated / real time per step within "
            f"{TOLERANCE:.0%} for {'every' if ok else 'NOT every'} rank count checked.")

