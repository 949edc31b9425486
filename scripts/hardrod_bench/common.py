"""Paths, formatting and file helpers shared by every harness.

Where the binaries are, how results directories are named, how tables and numbers are
printed, how files are written (complete or not at all), and the header of every report.
Reading hardrod's own outputs is outputs.py; running it is runner.py.
"""

import csv
import datetime
import hashlib
import json
import math
import os
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
HARDROD = ROOT / "build" / "hardrod"
BENCH_KERNELS = ROOT / "build" / "bench" / "hardrod_bench_kernels"
NPROC = os.cpu_count() or 1


def has_plotting():
    """numpy and matplotlib importable (Debian's system python3 has them, a pyenv may not)."""
    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
        return True
    except ImportError:
        return False


def finite(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def clean(obj):
    """JSON-safe copy: NaN and infinities become null, paths become strings."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path, obj):
    """Write complete JSON or nothing: a temporary file renamed into place."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(clean(obj), indent=2, allow_nan=False) + "\n")
    os.replace(tmp, path)


def write_text(path, text):
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def write_csv(path, rows, columns):
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in columns})
    os.replace(tmp, path)

def g(x, digits=4):
    """Compact number for tables."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    return f"{x:.{digits}g}"


def pm(mean, err):
    """mean +/- err with the error's two significant digits deciding the decimals."""
    if mean is None:
        return "-"
    if not finite(err) or err <= 0:
        return f"{mean:.5g}" + (" (no error)" if err is None else "")
    decimals = min(8, max(0, 1 - int(math.floor(math.log10(err)))))
    return f"{mean:.{decimals}f} +/- {err:.{decimals}f}"


def markdown_table(headers, rows):
    """A padded markdown table: readable on the terminal and in report.md alike."""
    cells = [[str(c) for c in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h)
              for i, h in enumerate(headers)]
    line = lambda r: "| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |"  # noqa: E731
    out = [line(headers), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    out += [line(r) for r in cells]
    return "\n".join(out)


def parse_list(text, kind=float):
    return [kind(v) for v in text.split(",") if v.strip()]


def relpath(p):
    try:
        return str(Path(p).resolve().relative_to(ROOT))
    except ValueError:
        return str(p)


def machine_info():
    info = {"nproc": NPROC, "load_average": list(os.getloadavg()), "hostname": os.uname().nodename}
    for b in (HARDROD, BENCH_KERNELS):  # which binary made these numbers (others may rebuild build/)
        if b.exists():
            info[b.name] = {"sha256": hashlib.sha256(b.read_bytes()).hexdigest(),
                            "modified": datetime.datetime.fromtimestamp(b.stat().st_mtime).isoformat(timespec="seconds")}
    if HARDROD.exists():
        try:
            info["hardrod_info"] = subprocess.run([str(HARDROD), "info"], capture_output=True,
                                                  text=True, timeout=30).stdout
        except (OSError, subprocess.SubprocessError) as e:
            info["hardrod_info"] = f"unavailable: {e}"
    return info


def ensure_built(args, binaries):
    missing = [b for b in binaries if not b.exists()]
    if not missing:
        return
    if args.dry_run:
        print(f"(dry run) would first build: scripts/build  ({', '.join(map(relpath, missing))} missing)")
        return
    print(f"bench: {', '.join(map(relpath, missing))} missing: running scripts/build", flush=True)
    subprocess.run([str(ROOT / "scripts" / "build")], cwd=ROOT, check=True)
    still = [b for b in binaries if not b.exists()]
    if still:
        sys.exit(f"bench: scripts/build did not produce {', '.join(map(relpath, still))}")


def make_outdir(args, name, with_runs=True):
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    base = Path(args.results).resolve() / f"{name}-{stamp}"
    out, k = base, 1
    while out.exists():
        k += 1
        out = base.with_name(f"{base.name}-{k}")
    if not args.dry_run:
        (out / "runs" if with_runs else out).mkdir(parents=True)
    return out


def busy_warning(loads):
    """A warning when other work shared the cores (1-minute load averages seen before runs)."""
    loads = [x for x in loads if x is not None]
    if loads and max(loads) > 0.5 * NPROC:
        return (f"WARNING: the machine was busy (1-minute load average up to {max(loads):.1f} on {NPROC} hardware "
                "threads before a run): timings and costs are inflated by other work.")
    return ""


def invocation():
    return "scripts/bench " + shlex.join(sys.argv[1:])


def report_header(title):
    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    return f"# {title}\n\nCommand: `{invocation()}`  \nDate: {now}  \nMachine: {os.uname().nodename}, {NPROC} hardware threads\n\n"


# ---- running hardrod ---------------------------------------------------------------------



# The default time step of each collision method (run.method): the paper's midpoint method at
# its P* bias of -0.22 %, the exact method (no dt bias) where its cost per tau is lowest.
DEFAULT_DT = {"midpoint": 1e-4, "exact": 1e-3}


def common_arguments(sp, threads_default=1, jobs=True):
    """The options every run-making sub-command shares."""
    sp.add_argument("--dry-run", action="store_true", help="print the runs it would do, run nothing")
    sp.add_argument("--results", default=str(ROOT / "results"), help="results root (default: results/)")
    if jobs:
        sp.add_argument("--threads", type=int, default=threads_default, help="OpenMP threads per run (default %(default)s)")
        sp.add_argument("--jobs", type=int, default=0,
                        help="runs at a time (default: hardware threads / --threads)")
        sp.add_argument("--seed", type=int, default=None, help="init.seed for every run (default: the scene's)")
        sp.add_argument("--reuse", default=None, metavar="RESULTS_DIR",
                        help="read runs with the same settings from an earlier results directory instead of "
                             "repeating them (re-judge or re-fit without re-running)")
