#!/usr/bin/env python3
"""scripts/render on a tiny run: a PNG of the asked size (read from its header) at
RUN_DIR/render.png and nothing else in the run directory, an explicit --out and a --slab
cut, and bad input refused by name (a run's own file as --out too, left as it was). Skipped (exit 77) where povray is not installed.

  check_render.py HARDROD SOURCE_DIR
"""
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile

SKIP = 77


def png_size(path):
    """(width, height) from a PNG's signature and IHDR chunk."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR", f"{path}: not a PNG"
    return struct.unpack(">II", head[16:24])


def main():
    hardrod, source = os.path.abspath(sys.argv[1]), pathlib.Path(sys.argv[2]).resolve()
    if not shutil.which("povray"):
        print("povray is not installed (Debian's povray; scripts/setup installs it): skipped")
        return SKIP
    render = [sys.executable, str(source / "scripts/render"), "--hardrod", hardrod]
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-render-test-"))
    failures = []
    try:
        run_dir = work / "run"
        subprocess.run([hardrod, "run", str(source / "scenes/default.toml"), "--out", str(run_dir),
                        "--quiet", "--threads", "1", "--set", "system.n=288", "--set",
                        "init.lattice=auto", "--set", "run.equilibration_steps=0", "--set",
                        "run.steps=20", "--set", "run.sample_interval=10"], check=True)
        files = sorted(p.name for p in run_dir.iterdir())
        r = subprocess.run(render + [str(run_dir), "--size", "160x120"], capture_output=True,
                           text=True)
        picture = run_dir / "render.png"
        if r.returncode != 0 or not picture.is_file():
            failures.append(f"render: exit {r.returncode}, {r.stderr.strip()[-500:]!r}")
        else:
            if png_size(picture) != (160, 120):
                failures.append(f"render.png is {png_size(picture)}, asked 160x120")
            left = sorted(p.name for p in run_dir.iterdir())
            if left != sorted(files + ["render.png"]):
                failures.append(f"the run directory holds {left}, was {files} + render.png")
        out = work / "slab.png"
        r = subprocess.run(render + [str(run_dir), "--size", "96x64", "--out", str(out),
                                     "--slab", "x:0:6", "--frame", "-1"],
                           capture_output=True, text=True)
        if r.returncode != 0 or not out.is_file() or png_size(out) != (96, 64):
            failures.append(f"--slab --out: exit {r.returncode}, {r.stderr.strip()[-500:]!r}")
        elif "of 288 rods (centres with x in [0, 6) D)" not in r.stdout:
            failures.append(f"--slab: said {r.stdout.strip()!r}")
        for args, code, words in [(["--size", "160"], 1, "--size must look like 1200x900"),
                                  (["--slab", "q:0:1"], 1, "--slab q:0:1"),
                                  (["--slab", "x:500:600"], 2, "no rod centre lies in it")]:
            r = subprocess.run(render + [str(run_dir), "--out", str(work / "bad.png"), *args],
                               capture_output=True, text=True)
            if r.returncode != code or words not in r.stderr or (work / "bad.png").exists():
                failures.append(f"{args}: exit {r.returncode}, said {r.stderr.strip()!r}")
        summary = (run_dir / "summary.json").read_bytes()
        r = subprocess.run(render + [str(run_dir), "--out", str(run_dir / "summary.json")],
                           capture_output=True, text=True)
        if r.returncode != 1 or (run_dir / "summary.json").read_bytes() != summary:
            failures.append(f"--out RUN_DIR/summary.json: exit {r.returncode}, {r.stderr!r}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print("scripts/render wrote PNGs of the asked sizes, a slab, and refused bad input")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
