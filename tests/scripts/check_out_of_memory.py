#!/usr/bin/env python3
"""A run that cannot get its memory (address space capped with RLIMIT_AS) ends with a clear
message and exit status 70, leaves no run directory behind, and does not crash (before: an
unhandled std::bad_alloc, rc 134 and an abort trace).  Usage: check_out_of_memory.py HARDROD SOURCE"""
import pathlib
import resource
import shutil
import subprocess
import sys
import tempfile


def main():
    hardrod, source = sys.argv[1], pathlib.Path(sys.argv[2])
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-oom-"))
    try:
        out = work / "huge"
        cap = 3 * 1024 ** 3  # 3 GiB of address space; 5e7 bodies need about 6.4 GB

        def limit():
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

        p = subprocess.run([hardrod, "run", str(source / "scenes/default.toml"), "--quiet",
                            "--threads", "1", "--set", "system.n=50000000", "--set",
                            "init.lattice=\"auto\"", "--out", str(out)],
                           capture_output=True, text=True, preexec_fn=limit, timeout=300)
        print(p.stderr.strip())
        assert p.returncode == 70, (p.returncode, p.stderr)
        assert "out of memory" in p.stderr, p.stderr
        assert not out.exists(), sorted(out.iterdir())
        print("check_out_of_memory: ok")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
