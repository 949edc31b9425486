"""What the checks of `scripts/bench` share: a named check, and the CLI run in this process."""

import contextlib
import io
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
from hardrod_bench import cli  # noqa: E402


def check(condition, message):
    if not condition:
        raise SystemExit(f"FAILED: {message}")
    print(f"ok: {message}")


def run_cli(argv):
    """(exit status or SystemExit message, stdout) of `scripts/bench ARGV` in this process."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            status = cli.main(argv)
        except SystemExit as e:
            status = e.code
    return status, out.getvalue()
