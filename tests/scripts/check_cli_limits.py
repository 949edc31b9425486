#!/usr/bin/env python3
"""hardrod's count options refuse values out of range by name, before anything is written:
--threads beyond any node's hardware threads, a --grid that would wrap an int or exceed an MPI
job; more threads than this process may use runs, with a warning. An unknown command is named
as one, an empty --out is refused rather than taken as no --out, a section given to --set as a
key is named as one, and many threads keep the placement report to a line.

  check_cli_limits.py HARDROD SOURCE_DIR
"""

import os
import pathlib
import subprocess
import sys
import tempfile


def main():
    hardrod, source = os.path.abspath(sys.argv[1]), pathlib.Path(sys.argv[2]).resolve()
    scene = str(source / "scenes/everyday.toml")
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-cli-"))
    short = ["--set", "run.equilibration_steps=0", "--set", "run.steps=20", "--set", "run.sample_interval=10",
             "--quiet"]

    def run(name, *args):
        out = work / name
        p = subprocess.run([hardrod, "run", scene, "--out", str(out), *short, *args],
                           capture_output=True, text=True)
        return p, out

    failures = []
    for name, args, want in [
        ("threads", ["--threads", "10000"], "--threads must be at most 4096, got '10000'"),
        ("grid-wrap", ["--grid", "99999999999x1x1"], "at most 1048576 ranks along an axis"),
        ("grid-many", ["--grid", "1048576x1048576x1"], "more than the 1073741824 an MPI job can have"),
        ("grid-form", ["--grid", "2x2"], "--grid must look like 2x2x1"),
    ]:
        p, out = run(name, *args)
        text = p.stdout + p.stderr
        if p.returncode == 0 or want not in text or out.exists():
            failures.append(f"{args}: exit {p.returncode}, wrote {out.exists()}, said {text.strip()[:300]!r}")
    usable = len(os.sched_getaffinity(0))
    p, _ = run("over", "--threads", str(usable + 1))
    if p.returncode != 0 or f"--threads {usable + 1} is more than the {usable} hardware threads" not in p.stderr:
        failures.append(f"--threads {usable + 1}: exit {p.returncode}, said {p.stderr.strip()[:300]!r}")
    # Many threads: the placement report stays a line, not one entry per thread.
    p = subprocess.run([hardrod, "run", scene, "--out", str(work / "many"), "--threads", "40",
                        "--force", *short[:-1]], capture_output=True, text=True)
    longest = max((len(line) for line in (p.stdout + p.stderr).splitlines()), default=0)
    if p.returncode != 0 or longest > 500:
        failures.append(f"--threads 40: exit {p.returncode}, longest line {longest} characters")
    # A section named as a key: its keys, not a look-alike from another section.
    p, out = run("section", "--set", "run=1")
    if p.returncode != 2 or "'run' is a section" not in p.stderr or "system.n" in p.stderr:
        failures.append(f"--set run=1: exit {p.returncode}, said {p.stderr.strip()[:300]!r}")
    p = subprocess.run([hardrod, "frobnicate"], capture_output=True, text=True)
    if p.returncode != 1 or "unknown command: frobnicate" not in p.stderr:
        failures.append(f"frobnicate: exit {p.returncode}, said {p.stderr.strip()[:300]!r}")
    for verb in (["run", scene], ["analyze", str(work)], ["export", str(work / "trajectory.h5")]):
        p = subprocess.run([hardrod, *verb, "--out", ""], capture_output=True, text=True, cwd=work)
        if p.returncode != 1 or "--out must name a path, got ''" not in p.stderr:
            failures.append(f"{verb[0]} --out '': exit {p.returncode}, said {p.stderr.strip()[:300]!r}")
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print("count options refused out of range, oversubscription warned; unknown command and "
              "empty --out named")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
