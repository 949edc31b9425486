#!/usr/bin/env python3
"""`hardrod export --out` replaces only a regular file, or creates one: a FIFO, a directory,
a symbolic link (and a temporary FILE.tmp that is one of those), the input trajectory, the
run's checkpoint and its other files beside the input (also by another path or under another
name) are refused with exit status 2, a message naming --out and the path, and nothing
changed. An .h5 name takes XYZ only with --format xyz. /dev/null is tried last, once the
other refusals held, and checked unchanged (stat before and after): an export that renamed
over it would turn it into a regular file.

  check_export_targets.py HARDROD SOURCE_DIR
"""
import hashlib
import os
import pathlib
import shutil
import stat
import subprocess
import sys
import tempfile


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def export(hardrod, *args):
    return subprocess.run([hardrod, "export", *map(str, args)], capture_output=True, text=True)


def main():
    hardrod, source = os.path.abspath(sys.argv[1]), pathlib.Path(sys.argv[2]).resolve()
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-export-targets-"))
    failures = []

    def refused(out, *extra, words=()):
        """Export to `out` must exit 2 naming --out and `out` (and `words`)."""
        r = export(hardrod, trajectory, "--out", out, *extra)
        said = r.stderr.strip()
        if digest(trajectory) != kept:  # put back, so that each case is judged on its own
            failures.append(f"--out {out}: changed the input trajectory")
            shutil.copyfile(work / "pristine.h5", trajectory)
        if r.returncode != 2 or f"--out {out}" not in said or not all(w in said for w in words):
            failures.append(f"--out {out} {' '.join(extra)}: exit {r.returncode}, said {said[:300]!r}")
            return False
        return True

    try:
        run_dir = work / "run"
        subprocess.run([hardrod, "run", str(source / "scenes/default.toml"), "--out", str(run_dir),
                        "--quiet", "--threads", "1", "--set", "system.n=288", "--set",
                        "init.lattice=auto", "--set", "run.equilibration_steps=0", "--set",
                        "run.steps=20", "--set", "run.sample_interval=10"], check=True)
        trajectory = run_dir / "trajectory.h5"
        shutil.copyfile(trajectory, work / "pristine.h5")
        kept = digest(trajectory)
        own = sorted(p for p in run_dir.iterdir() if p.is_file())
        before = {p.name: digest(p) for p in own}

        # Not regular files: a FIFO, a directory, links (to a file, dangling), a link as FILE.tmp.
        fifo, folder = work / "pipe", work / "folder"
        os.mkfifo(fifo)
        folder.mkdir()
        mine = work / "mine.txt"
        mine.write_text("the user's file\n")
        link, dangling = work / "link.xyz", work / "dangling.xyz"
        link.symlink_to(mine)
        dangling.symlink_to(work / "nowhere")
        (work / "t.xyz.tmp").symlink_to(mine)
        guarded = all([refused(fifo, words=["FIFO"]), refused(folder, words=["directory"]),
                       refused(link, words=["symbolic link"]),
                       refused(dangling, words=["symbolic link"]),
                       refused(work / "t.xyz", words=["t.xyz.tmp", "symbolic link"])])
        if not (stat.S_ISFIFO(os.lstat(fifo).st_mode) and folder.is_dir() and link.is_symlink()
                and dangling.is_symlink() and mine.read_text() == "the user's file\n"
                and not (work / "t.xyz").exists()):
            failures.append("a refused --out was changed")

        # The run's own files: the input, the checkpoint and the others, by name, through a
        # linked directory and under another name (a hard link).
        for name in ["trajectory.h5", "checkpoint.h5", "checkpoint.prev.h5", "summary.json",
                     "scene.toml", "timeseries.csv", "frank.json", "analysis.json"]:
            guarded &= refused(run_dir / name, "--format", "xyz")
        alias = work / "alias"
        alias.symlink_to(run_dir, target_is_directory=True)
        guarded &= refused(alias / "trajectory.h5", "--format", "xyz", words=["input"])
        guarded &= refused(alias / "summary.json", words=["one of the run's own files"])
        hard = work / "hard.xyz"
        os.link(run_dir / "checkpoint.h5", hard)
        guarded &= refused(hard, words=["the same file as", "checkpoint.h5"])
        after = {p.name: digest(p) for p in own}
        if after != before or sorted(p for p in run_dir.iterdir() if p.is_file()) != own:
            failures.append(f"the run's files changed: {before} -> {after}")

        # An .h5 name: XYZ only when asked for.
        guarded &= refused(work / "out.h5", words=[".h5", "--format xyz"])
        r = export(hardrod, trajectory, "--out", work / "out.h5", "--format", "xyz")
        if r.returncode != 0 or not (work / "out.h5").read_text().startswith("288\n"):
            failures.append(f"--format xyz --out out.h5: exit {r.returncode}, {r.stderr.strip()!r}")
        # Into a folder that is not there: the reason, not only "cannot create".
        r = export(hardrod, trajectory, "--out", work / "missing" / "x.xyz")
        if r.returncode != 2 or "no folder" not in r.stderr:
            failures.append(f"--out into a missing folder: exit {r.returncode}, {r.stderr.strip()!r}")
        # A regular file is replaced, as before.
        target = work / "t.gsd"
        target.write_text("old\n")
        r = export(hardrod, trajectory, "--out", target)
        if r.returncode != 0 or target.read_bytes()[:4] == b"old\n":
            failures.append(f"--out an existing regular file: exit {r.returncode}, {r.stderr!r}")

        if guarded:  # only an export that refuses the rest is let near /dev/null
            null_before = os.stat("/dev/null")
            refused("/dev/null", words=["device"])
            null_after = os.stat("/dev/null")
            if not (stat.S_ISCHR(null_after.st_mode) and null_after.st_ino == null_before.st_ino
                    and null_after.st_rdev == null_before.st_rdev):
                failures.append("/dev/null is no longer the device it was")
        else:
            failures.append("/dev/null not tried: the refusals above failed")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print("export refused FIFO, directory, links, its own input, the run's files, an .h5 "
              "name without --format and /dev/null, changing nothing")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
