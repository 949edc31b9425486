#!/usr/bin/env python3
"""The set-up before the first step, when things go wrong:
- a run that cannot get its memory (address space capped with RLIMIT_AS) ends with a clear
  message and exit status 70 and leaves no run directory (before: an unhandled
  std::bad_alloc, an abort trace);
- SIGTERM during the isotropic compression (several seconds at N = 2304) stops the run within
  a second with exit status 4, saying nothing was written, and leaves no run directory
  (before: honoured only after the compression and the first burst of steps).
Usage: check_setup.py HARDROD SOURCE"""
import pathlib
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time


def out_of_memory(hardrod, scene, work):
    out = work / "huge"
    cap = 3 * 1024 ** 3  # 3 GiB of address space; 5e7 bodies need about 6.4 GB

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    p = subprocess.run([hardrod, "run", str(scene), "--quiet", "--threads", "1", "--set",
                        "system.n=50000000", "--set", "init.lattice=\"auto\"", "--out", str(out)],
                       capture_output=True, text=True, preexec_fn=limit, timeout=300)
    print(p.stderr.strip())
    assert p.returncode == 70, (p.returncode, p.stderr)
    assert "out of memory" in p.stderr, p.stderr
    assert not out.exists(), sorted(out.iterdir())


def signal_during_compression(hardrod, scene, work):
    out = work / "isotropic"
    p = subprocess.Popen([hardrod, "run", str(scene), "--quiet", "--threads", "1", "--set",
                          "init.configuration=\"isotropic\"", "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    assert p.poll() is None, "the compression ended before the signal: the test needs a longer one"
    start = time.monotonic()
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    waited = time.monotonic() - start
    print(f"{err.strip()} (exit {p.returncode} after {waited:.2f} s)")
    assert p.returncode == 4, (p.returncode, err)
    assert "during the set-up" in err and "SIGTERM" in err, err
    assert waited < 1.0, waited
    assert not out.exists(), sorted(out.iterdir())


def main():
    hardrod, source = sys.argv[1], pathlib.Path(sys.argv[2])
    work = pathlib.Path(tempfile.mkdtemp(prefix="hardrod-setup-"))
    try:
        out_of_memory(hardrod, source / "scenes/default.toml", work)
        signal_during_compression(hardrod, source / "scenes/default.toml", work)
        print("check_setup: ok")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
