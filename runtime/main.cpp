// The hardrod command line: `hardrod run SCENE.toml [--set key=value ...] [--out DIR]`,
// `hardrod resume DIR [--set run.steps=N]`, `hardrod analyze DIR...`,
// `hardrod export TRAJECTORY.h5 [--frame K] [--format xyz|gsd|pov]`, `hardrod info`. One
// function declares each verb's options, one carries it out; the work itself is in runtime/
// (run.hpp, analyze.hpp, export.hpp, info.hpp).
// Exit status: 0 success, 1 usage, 2 bad scene, output directory or checkpoint, 3 the
// physics broke (overlap beyond tolerance, NaN): the message says which step and dt,
// 4 stopped by SIGTERM/SIGUSR1/SIGINT after writing a checkpoint (resume continues it).
#ifdef HARDROD_SMPI
// SMPI's smpi_helpers.h makes exit(x) a macro, which would rename CLI::App::exit; nothing here
// calls the C library's exit (main returns its status).
#undef exit
#endif
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <functional>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/isotropic_start.hpp"
#include "runtime/analyze.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/comm.hpp"
#include "runtime/export.hpp"
#include "runtime/info.hpp"
#include "runtime/provenance.hpp"
#include "runtime/run.hpp"
#include "runtime/scene.hpp"
#include "runtime/signals.hpp"
#include "runtime/snapshot.hpp"
#include "runtime/system.hpp"

namespace {

// A check for options that take a whole number in [1, largest], naming the option and the value.
CLI::Validator positive(const std::string &option, long long largest) {
  return CLI::Validator(
      [option, largest](std::string &value) {
        std::size_t used = 0;
        long long n = 0;
        try {
          n = std::stoll(value, &used);
        } catch (const std::exception &) {
          used = 0;
        }
        if (used != value.size() || used == 0 || n < 1)
          return option + " must be a positive whole number, got '" + value + "'";
        if (n > largest)
          return fmt::format("{} must be at most {}, got '{}'", option, largest, value);
        return std::string();
      },
      "POSITIVE");
}

// --out names a place: an empty value would silently mean no --out.
std::string named_path(const std::string &value) {
  return value.empty() ? std::string("--out must name a path, got ''") : std::string();
}

// Threads per rank: beyond any node's hardware threads, a typo, not a plan.
constexpr long long kMaxThreads = 4096;
// Ranks along one axis of --grid, and in all (MPI's ranks are int).
constexpr long long kMaxGridAxis = 1 << 20;
constexpr long long kMaxGridRanks = 1 << 30;

// --grid AxBxC: three whole numbers in [1, kMaxGridAxis] with a product of at most
// kMaxGridRanks; an empty string when it is one, the reason otherwise.
std::string grid_problem(const std::string &g) {
  const std::string form = "--grid must look like 2x2x1 (three positive integers), got '" + g + "'";
  std::array<long long, 3> n{};
  std::size_t at = 0;
  for (int a = 0; a < 3; ++a) {
    const std::size_t end = a < 2 ? g.find('x', at) : g.size();
    if (end == std::string::npos || end == at) return form;
    const std::string part = g.substr(at, end - at);
    if (part.find_first_not_of("0123456789") != std::string::npos) return form;
    n[a] = part.size() > 9 ? kMaxGridAxis + 1 : std::stoll(part);  // digits only: no overflow
    if (n[a] < 1) return form;
    if (n[a] > kMaxGridAxis)
      return fmt::format("--grid {}: at most {} ranks along an axis", g, kMaxGridAxis);
    at = end + 1;
  }
  if (n[0] * n[1] * n[2] > kMaxGridRanks)
    return fmt::format("--grid {}: {} ranks, more than the {} an MPI job can have", g,
                       n[0] * n[1] * n[2], kMaxGridRanks);
  return "";
}

// The options of a process that steps a simulation: the same for run and resume.
struct ExecutionArgs {
  hardrod::RunOptions options;
  int threads = 0;
  bool quiet = false;
  bool no_bind = false;
  std::string grid;
  std::string balance = "time";
};

void add_execution_options(CLI::App *cmd, ExecutionArgs &e) {
  cmd->add_option("--threads", e.threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)")
      ->check(positive("--threads", kMaxThreads));
  cmd->add_flag("--quiet", e.quiet, "no progress output");
  cmd->add_flag("--no-bind", e.no_bind, "do not bind OpenMP threads to cores");
  cmd->add_flag("--verify", e.options.verify,
                "after every step check that every body is owned once and every shadow equals "
                "its owner (slow; for debugging)");
  cmd->add_option("--grid", e.grid, "MPI process grid, e.g. 2x2x1 (default: MPI_Dims_create)")
      ->check(grid_problem);
  cmd->add_option("--balance", e.balance,
                  "move the subdomain cuts so the ranks carry equal loads: time (measured "
                  "compute time, default), bodies (advanced bodies, deterministic) or off")
      ->check([](const std::string &m) {
        try {
          hardrod::parse_balance_mode(m);  // the one list of the modes' names
          return std::string();
        } catch (const std::invalid_argument &e) {
          return std::string(e.what());
        }
      });
  cmd->add_flag("--results-exchange", e.options.parallel.results_exchange,
                "for tests: resolve a cluster that spans ranks only on the rank that counts "
                "it and send its results to the others")
      ->group("");  // not in --help
  cmd->add_option("--balance-interval", e.options.parallel.balance.interval,
                  "steps between load comparisons (default 1000)")
      ->check(positive("--balance-interval", 1000000000000LL));  // 10^12: no step overflow
  cmd->add_option("--balance-threshold", e.options.parallel.balance.threshold,
                  "move the cuts when the busiest rank's load is this far above the mean "
                  "(relative; default 0.05)")
      ->check([](const std::string &value) {
        std::size_t used = 0;
        double x = 0.0;
        try {
          x = std::stod(value, &used);
        } catch (const std::exception &) {
          used = 0;
        }
        if (used != value.size() || used == 0 || !(x >= 0.0 && x < 1e6))
          return "--balance-threshold must be a number from 0 up, got '" + value + "'";
        return std::string();
      });
}

// `hardrod run SCENE`.
struct RunArgs {
  std::string scene_path;
  std::vector<std::string> overrides;
};

CLI::App *add_run_command(CLI::App &app, RunArgs &r, ExecutionArgs &e) {
  auto *run = app.add_subcommand("run", "run a scene file");
  run->add_option("scene", r.scene_path, "scene file (TOML)")->required();
  run->add_option("--set", r.overrides, "override a scene key, e.g. --set run.dt=1e-4")
      ->type_name("KEY=VALUE");
  run->add_option("--out", e.options.output_dir,
                  "output directory (default: the scene's output.dir)")
      ->check(named_path);
  run->add_flag("--force", e.options.force, "overwrite an existing run in the output directory");
  add_execution_options(run, e);
  return run;
}

// `hardrod resume DIR`.
struct ResumeArgs {
  std::string dir, checkpoint_path;
  std::vector<std::string> overrides;
};

CLI::App *add_resume_command(CLI::App &app, ResumeArgs &r, ExecutionArgs &e) {
  auto *resume = app.add_subcommand(
      "resume", "continue a run from its newest checkpoint, exactly, to its (raised) step target");
  resume->add_option("dir", r.dir, "run directory")->required();
  resume
      ->add_option("--set", r.overrides,
                   "raise the target or change output intervals, e.g. --set run.steps=200000")
      ->type_name("KEY=VALUE");
  resume->add_option("--checkpoint", r.checkpoint_path,
                     "checkpoint file to continue from (default: DIR/checkpoint.h5)");
  add_execution_options(resume, e);
  return resume;
}

// `hardrod export TRAJECTORY.h5 [--frame K] [--format xyz|gsd|pov] [--out FILE]
// [--slab AXIS:FROM:TO]`.
struct ExportArgs {
  std::string file, out, format, slab;
  std::optional<long long> frame;  // none: every frame (POV: the last)
};

CLI::App *add_export_command(CLI::App &app, ExportArgs &x) {
  auto *export_cmd = app.add_subcommand(
      "export",
      "write an H5MD trajectory's frames as extended XYZ (ASE, OVITO) or GSD (HOOMD-blue, OVITO, "
      "freud, MDAnalysis), or one frame as a POV-Ray scene (scripts/render makes the picture)");
  export_cmd->add_option("file", x.file, "H5MD file, e.g. DIR/trajectory.h5")->required();
  export_cmd->add_option(
      "--frame", x.frame,
      "only this frame (< 0 counts from the end; default: every frame, for pov the last)");
  export_cmd
      ->add_option("--out", x.out,
                   "output file, written to FILE.tmp and renamed (default: standard output, "
                   "xyz and pov only); refused if something other than a regular file is there "
                   "(a symbolic link too: give its target), if it is the input or one of the "
                   "run's own files beside it")
      ->check(named_path);
  export_cmd
      ->add_option("--format", x.format,
                   "xyz, gsd or pov (default: from --out's extension, .gsd, .pov, xyz "
                   "otherwise; an .h5 name only with --format)")
      ->check(CLI::IsMember({"xyz", "gsd", "pov"}));
  export_cmd
      ->add_option("--slab", x.slab,
                   "pov: only the rods whose centres, folded into the box, lie in FROM <= c < "
                   "TO along AXIS (in D), e.g. x:0:10")
      ->type_name("AXIS:FROM:TO")
      ->check([](const std::string &s) {
        try {
          hardrod::parse_slab(s);
          return std::string();
        } catch (const std::invalid_argument &e) {
          return std::string(e.what());
        }
      });
  return export_cmd;
}

// `hardrod analyze DIR...`: its options fill `o` (and `no_plots`).
CLI::App *add_analyze_command(CLI::App &app, hardrod::AnalyzeOptions &o, bool &no_plots) {
  auto *analyze = app.add_subcommand(
      "analyze", "merge runs: S, P* and the Frank constants with errors, analysis.json, plots");
  analyze->add_option("dirs", o.run_dirs, "run directories")->required();
  analyze
      ->add_option("--out", o.output_dir,
                   "where analysis.json and the plots go (default: the first run directory)")
      ->check(named_path);
  analyze->add_flag("--subtract-self-term", o.frank.subtract_self_term,
                    "remove the uncorrelated-rod background from <|Q_m3|^2> before fitting");
  analyze
      ->add_option("--planar-max-k2", o.frank.planar_max_k2,
                   "planar fit: bins with k1^2 and k3^2 below this, D^-2 (default 0.1)")
      ->check(CLI::PositiveNumber);
  analyze
      ->add_option("--cubic-max-k1sq", o.frank.cubic_max_k1sq,
                   "cubic and background fits: bins with k1^2 up to this, D^-2 (default 2)")
      ->check(CLI::PositiveNumber);
  analyze
      ->add_option("--cubic-max-k3sq", o.frank.cubic_max_k3sq,
                   "cubic and background fits: bins with k3^2 up to this, D^-2 (default 1)")
      ->check(CLI::PositiveNumber);
  analyze->add_flag("--no-plots", no_plots, "skip the PNG figures");
  analyze->add_flag("--allow-mixed", o.allow_mixed,
                    "merge runs of different run.dt, run.method or observables.fourier_kmax");
  analyze->add_flag("--strict", o.strict,
                    "exit 3 when a run is not equilibrated or the recommended fit is not trusted "
                    "(analysis.json is written all the same)");
  return analyze;
}

int info_command() {
  fmt::print("{}", hardrod::build_info());
  return 0;
}

int export_command(const ExportArgs &x) {
  try {
    const hardrod::ExportFormat format = hardrod::choose_export_format(x.format, x.out);
    if (!x.slab.empty() && format != hardrod::ExportFormat::kPov) {
      fmt::print(stderr, "hardrod export: --slab: only for a POV-Ray scene (--format pov)\n");
      return 1;
    }
    std::optional<hardrod::PovSlab> slab;
    if (!x.slab.empty()) slab = hardrod::parse_slab(x.slab);
    hardrod::export_trajectory(x.file, x.frame, x.out, format, slab);
  } catch (const std::exception &e) {
    fmt::print(stderr, "hardrod export: {}\n", e.what());
    return 2;
  }
  return 0;
}

int analyze_command(hardrod::AnalyzeOptions &o, bool no_plots) {
  o.plots = !no_plots;
  try {
    const nlohmann::json analysis = hardrod::analyze_runs(o);
    if (o.strict && !hardrod::analysis_trusted(analysis)) {
      fmt::print(stderr,
                 "hardrod analyze: --strict: the analysis is not trusted (see the "
                 "warnings and analysis.json's equilibrated and frank_fits)\n");
      return 3;
    }
  } catch (const std::exception &e) {
    fmt::print(stderr, "hardrod analyze: {}\n", e.what());
    return 2;
  }
  return 0;
}

// run and resume: threads and options from the flags, the stop signals, MPI, then `body`;
// its exceptions become the exit status. Problems are found identically on every rank;
// rank 0 reports them (`source` names the scene file or run directory).
int simulate_command(ExecutionArgs &e, const std::string &source,
                     const std::function<void(const hardrod::RunOptions &)> &body) {
  hardrod::RunOptions &options = e.options;
  if (e.threads > 0) omp_set_num_threads(e.threads);
  if (e.threads > omp_get_num_procs())
    fmt::print(stderr,
               "hardrod: warning: --threads {} is more than the {} hardware threads this process "
               "may use: the threads share cores and the run is slower\n",
               e.threads, omp_get_num_procs());
  options.quiet = e.quiet;
  options.parallel.report_setup = !e.quiet;
  options.bind = !e.no_bind;
  options.parallel.balance.mode = hardrod::parse_balance_mode(e.balance);
  if (!e.grid.empty())
    std::sscanf(e.grid.c_str(), "%dx%dx%d", &options.parallel.grid[0], &options.parallel.grid[1],
                &options.parallel.grid[2]);
  hardrod::install_stop_signals();  // before MPI start-up, so that no signal is lost
  hardrod::Communicator comm;       // initialises MPI (a single process without mpirun)
  try {
    body(options);
  } catch (const hardrod::SceneError &err) {
    if (comm.is_root()) {
      fmt::print(stderr, "hardrod: error in {}:\n", source);
      for (const auto &p : err.problems()) fmt::print(stderr, "  {}\n", p);
    }
    return 2;
  } catch (const hardrod::CheckpointError &err) {
    if (comm.is_root()) fmt::print(stderr, "hardrod: cannot resume: {}\n", err.what());
    return 2;
  } catch (const hardrod::PhysicsError &err) {
    if (comm.is_root()) fmt::print(stderr, "hardrod: the run stopped: {}\n", err.what());
    return 3;
  } catch (const hardrod::RunOutputError &err) {
    if (comm.is_root()) fmt::print(stderr, "hardrod: the run stopped: {}\n", err.what());
    return 2;
  } catch (const hardrod::RunInterrupted &err) {
    if (comm.is_root()) fmt::print(stderr, "hardrod: {}\n", err.what());
    return 4;
  } catch (const hardrod::CompressionStopped &) {
    fmt::print(stderr,
               "hardrod: stopped by {} during the set-up (the isotropic compression), before "
               "anything was written: run the command again\n",
               hardrod::stop_signal_name());
    return 4;
  } catch (const std::bad_alloc &) {
    fmt::print(stderr, "hardrod: out of memory on rank {} (a smaller system.n, or more ranks)\n",
               comm.rank());
    if (comm.size() > 1) comm.abort(70);
    return 70;
  } catch (const std::exception &err) {
    // Not one of the run's own errors (e.g. out of memory): it may have reached this rank
    // only, so the job ends on every rank rather than leaving the others waiting.
    fmt::print(stderr, "hardrod: internal error on rank {}: {}\n", comm.rank(), err.what());
    if (comm.size() > 1) comm.abort(70);
    return 70;
  }
  return 0;
}

int run_command(const RunArgs &r, ExecutionArgs &e) {
  return simulate_command(e, r.scene_path, [&r](const hardrod::RunOptions &options) {
    const hardrod::Scene scene = hardrod::load_scene(r.scene_path, r.overrides);
    hardrod::run_scene(scene, options);
  });
}

int resume_command(const ResumeArgs &r, ExecutionArgs &e) {
  return simulate_command(e, r.dir, [&r](const hardrod::RunOptions &options) {
    hardrod::resume_run(r.dir, r.overrides, options, r.checkpoint_path);
  });
}

int run_verb(int argc, char **argv) {
  hardrod::record_command_line(argc, argv);  // summary.json and trajectory.h5 name the call
  CLI::App app{"hardrod: hard-spherocylinder liquid crystals by hard-contact rigid-body dynamics"};
  app.require_subcommand(1);
  ExecutionArgs execution;
  RunArgs run_args;
  ResumeArgs resume_args;
  ExportArgs export_args;
  hardrod::AnalyzeOptions analyze_options;
  bool no_plots = false;
  CLI::App *run = add_run_command(app, run_args, execution);
  add_resume_command(app, resume_args, execution);
  CLI::App *export_cmd = add_export_command(app, export_args);
  CLI::App *info = app.add_subcommand("info", "print the build configuration and the machine");
  CLI::App *analyze = add_analyze_command(app, analyze_options, no_plots);

  std::vector<std::string> names;
  for (const CLI::App *c : app.get_subcommands([](CLI::App *) { return true; }))
    names.push_back(c->get_name());
  if (argc > 1 && argv[1][0] != '-' &&
      std::find(names.begin(), names.end(), argv[1]) == names.end()) {
    fmt::print(stderr, "hardrod: unknown command: {} (commands: {}; see --help)\n", argv[1],
               fmt::join(names, ", "));
    return 1;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError &e) {
    // --help and --version exit 0; every bad command line exits 1, as README.md says
    // (CLI11's own codes, 105 for a failed check and so on, are not part of the interface).
    const int code = app.exit(e);
    return code == 0 ? 0 : 1;
  }
  if (info->parsed()) return info_command();
  if (export_cmd->parsed()) return export_command(export_args);
  if (analyze->parsed()) return analyze_command(analyze_options, no_plots);
  if (run->parsed()) return run_command(run_args, execution);
  return resume_command(resume_args, execution);
}

}  // namespace

int main(int argc, char **argv) {
  hardrod::keep_hdf5_out_of_exit();
  const int status = run_verb(argc, argv);
  hardrod::finalize_communication();
  return status;
}
