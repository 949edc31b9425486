#!/usr/bin/env python3
"""`scripts/bench instructions` without valgrind: reading callgrind_annotate and the flags.

1. The parser on two outputs of callgrind_annotate as valgrind 3.19 prints them: one event
   (Ir) and the nine of --cache-sim, where a cost may be "." or a bare 0; the totals, each
   function's costs in the order of the events, and the names shortened to the function
   (parameters, templates, clones, the file and the object dropped), clones added up.
2. Unknown --systems are refused naming the value, a missing --binary naming the path; the
   dry run lists one counted run per system and build, and runs nothing.
"""

import pathlib
import tempfile

from bench_cli import check, run_cli
from hardrod_bench import instructions

ONE_EVENT = """\
Events recorded:  Ir
Events shown:     Ir
--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
1,112,387,859 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                    file:function
--------------------------------------------------------------------------------
327,546,172 (29.45%)  ???:hardrod::(anonymous namespace)::find_pairs(hardrod::(anonymous namespace)::PairSearch const&, std::vector<hardrod::ListedPair, std::allocator<hardrod::ListedPair> >&) [clone ._omp_fn.0] [/tmp/b/hardrod]
 83,323,604 ( 7.49%)  ???:void hardrod::(anonymous namespace)::due_distances<false>(hardrod::Particles const&, hardrod::Box const&) [clone .constprop.0] [/tmp/b/hardrod]
 29,798,256 ( 2.68%)  ./math/../sysdeps/x86_64/fpu/multiarch/s_nearbyint-sse4_1.S:__nearbyint_sse41 [/usr/lib/x86_64-linux-gnu/libm.so.6]
  1,000,000 ( 0.09%)  ???:void hardrod::(anonymous namespace)::due_distances<true>(hardrod::Particles const&, hardrod::Box const&) [/tmp/b/hardrod]
  4,698,723 ( 0.42%)  ???:hardrod::arm_watches(hardrod::NeighborList&) [clone ._omp_fn.0] [/tmp/b/hardrod]
  3,000,000 ( 0.27%)  ???:hardrod::Flight::axis(double) const [/tmp/b/hardrod]
"""

CACHE_SIM = """\
Events shown:     Ir Dr Dw I1mr D1mr D1mw ILmr DLmr DLmw
150,372,743 (100.0%) 34,205,934 (100.0%) 12,545,789 (100.0%) 72,211 (100.0%) 1,383,526 (100.0%) 315,556 (100.0%) 1,127 (100.0%) 22 (100.0%) 15,191 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                  Dr                 Dw                 I1mr           D1mr             D1mw            ILmr         DLmr        DLmw            file:function
--------------------------------------------------------------------------------
49,172,800 (32.70%) 8,009,334 (23.42%) 1,965,356 (15.67%)   136 ( 0.19%)  91,303 ( 6.60%) 36,546 (11.58%)   .           .              .           ???:hardrod::(anonymous namespace)::find_pairs(hardrod::(anonymous namespace)::PairSearch const&) [clone ._omp_fn.0] [/tmp/b/hardrod]
17,744,000 (11.80%) 2,650,850 ( 7.75%) 1,268,150 (10.11%)   850 ( 1.18%) 202,548 (14.64%)      0           17 ( 1.51%)  .              .           ???:double hardrod::(anonymous namespace)::drift<true, 2, false>(hardrod::Particles&, long, long, double) [clone .isra.0] [/tmp/b/hardrod]
"""


def parser():
    events, totals, functions = instructions.parse_annotate(ONE_EVENT)
    check(events == ["Ir"] and totals == [1112387859], "one event: the totals")
    names = [name for name, _ in functions]
    check(names == ["find_pairs", "due_distances", "__nearbyint_sse41", "due_distances",
                    "arm_watches", "Flight::axis"], f"one event: the functions' short names ({names})")
    merged = instructions.merged(functions)
    check(merged[0] == ("find_pairs", [327546172]) and
          dict(merged)["due_distances"] == [84323604], "clones and instances add up, largest first")
    events, totals, functions = instructions.parse_annotate(CACHE_SIM)
    check(len(events) == 9 and totals[4] == 1383526 and totals[7] == 22,
          "cache simulation: nine totals in the order of the events")
    check(functions[0] == ("find_pairs", [49172800, 8009334, 1965356, 136, 91303, 36546, 0, 0, 0]),
          "cache simulation: '.' counts as zero")
    check(functions[1] == ("drift", [17744000, 2650850, 1268150, 850, 202548, 0, 17, 0, 0]),
          "cache simulation: a bare 0 counts as zero, the return type dropped")


def flags():
    with tempfile.TemporaryDirectory() as tmp:
        results = ["--results", tmp]
        status, _ = run_cli(["instructions", "--dry-run", "--systems", "spheres,liquid", *results])
        check(isinstance(status, str) and "unknown liquid" in status,
              f"an unknown system is refused by name ({status})")
        status, _ = run_cli(["instructions", "--binary", f"{tmp}/none/hardrod", *results])
        check(isinstance(status, str) and f"{tmp}/none/hardrod" in status,
              f"a missing --binary is named ({status})")
        fake = pathlib.Path(tmp) / "hardrod"
        fake.write_text("")
        status, text = run_cli(["instructions", "--dry-run", "--binary", str(fake), "--binary",
                                str(fake), "--steps-scale", "0.5", *results])
        lines = [l for l in text.splitlines() if "under callgrind" in l]
        check(status == 0 and len(lines) == 6 and "spheres: 30 steps" in lines[0],
              f"the dry run lists a counted run per system and build ({lines})")
        check(not any(pathlib.Path(tmp).glob("instructions-*/runs")), "the dry run writes nothing")


if __name__ == "__main__":
    parser()
    flags()
    print("all checks passed")
