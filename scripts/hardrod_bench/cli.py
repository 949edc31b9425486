"""The command line of `scripts/bench`: one sub-command per harness module.

Builds the parser from each module's HELP, DESCRIPTION and add_arguments, and hands the
parsed arguments to the module's main. The order of the sub-commands here is the order of
`scripts/bench --help`.
"""

import argparse

from . import (ab, answer, balance, edmd, instructions, kernels, methods, paper, scaling, tradeoff, traffic,
               validate, versus)

USAGE = """hardrod benchmark harness: kernels, physics validation, speed/accuracy trade, scaling.

  scripts/bench kernels   [--filter RE] [--repetitions R] [--min-time S]
  scripts/bench instructions [--binary A --binary B] [--systems ...] [--cache-sim]   (callgrind)
  scripts/bench versus    [--rounds R] [--configs dt:skin,...]   (the speed goals, in turns)
  scripts/bench ab        --base REV | --binary A [--binary B] [--system nematic|spheres]   (side by side)
  scripts/bench edmd      --source DIR [--rounds R] [--dt DT --skin S]   (hard spheres against event-driven MD)
  scripts/bench validate  [--long | --strict] [--jobs J] [--threads T]
  scripts/bench tradeoff  [--quick | --long] [--methods midpoint,exact] [--jobs J] [--threads T]
  scripts/bench scaling   [--steps S] [--repeat R] [--threads-list 1,2]
  scripts/bench traffic   [--ranks-list 1,2,4,...]
  scripts/bench balance   [--ranks R] [--repeat R]   (load balancing on an uneven gas)
  scripts/bench answer    [--tau T] [--dt DT]   (time to answer from both sides)
  scripts/bench paper     [--dry-run] [--sizes 18432,2304] [--seeds 6]   (the paper's Table 1)
  scripts/bench methods   [--dry-run] [--seeds 6] [--variants exact:1e-3,...]   (methods from the same states)

Every sub-command drives the stable interface only (`build/hardrod run SCENE --set ...`,
`build/bench/hardrod_bench_kernels --benchmark_out=...`), writes under
results/<subcommand>-<timestamp>/ (CSV, JSON, report.md with the command and date, PNG
where it plots, and each run's own directory under runs/), and prints a table. A run that
fails (non-zero exit) is recorded with its exit status and message; the others go on.
`--dry-run` prints the runs it would do and touches nothing. bench/validation/README.md
and bench/tradeoff/README.md say how to read the output.
"""

# In the order of --help; paper before answer, as it always was.
HARNESSES = {"kernels": kernels, "instructions": instructions, "versus": versus, "ab": ab, "edmd": edmd,
             "validate": validate, "tradeoff": tradeoff, "scaling": scaling,
             "traffic": traffic, "balance": balance, "paper": paper, "methods": methods,
             "answer": answer}
RAW_DESCRIPTION = {"paper", "methods"}  # its description is a module docstring with line breaks


def parser():
    p = argparse.ArgumentParser(
        prog="scripts/bench", description=USAGE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Each sub-command writes results/<subcommand>-<timestamp>/ and prints where; "
               "`scripts/bench <cmd> --help` for its options, `--dry-run` to list its runs.")
    sub = p.add_subparsers(dest="command", required=True, metavar="{kernels,instructions,versus,ab,edmd,validate,tradeoff,scaling,traffic,balance,paper,methods,answer}")
    for name, module in HARNESSES.items():
        extra = {"formatter_class": argparse.RawDescriptionHelpFormatter} if name in RAW_DESCRIPTION else {}
        sp = sub.add_parser(name, help=module.HELP, description=module.DESCRIPTION, **extra)
        module.add_arguments(sp)
    return p


def main(argv=None):
    p = parser()
    args = p.parse_args(argv)
    if getattr(args, "threads", 1) < 1 or getattr(args, "jobs", 0) < 0:
        p.error("--threads must be >= 1 and --jobs >= 0")
    return HARNESSES[args.command].main(args)
