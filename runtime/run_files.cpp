// The run directory's files as the run writes them (see run_files.hpp).
#include "runtime/run_files.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string_view>

#include "runtime/run_state.hpp"

namespace hardrod {

namespace fs = std::filesystem;

void prepare_output_dir(const fs::path &dir, bool force) {
  std::error_code ec;
  if (!force && (fs::exists(dir / "summary.json", ec) || fs::exists(dir / "timeseries.csv", ec)))
    throw SceneError(
        {fmt::format("output.dir = \"{}\": already holds a run (summary.json or timeseries.csv); "
                     "choose another with --out DIR, or pass --force to overwrite it",
                     dir.string())});
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw SceneError({fmt::format("output.dir = \"{}\": cannot create directory ({})", dir.string(),
                                  ec.message())});
}

namespace {

// The files of a run directory by name (plots: scripts/plot_analysis.py; the picture:
// scripts/render).
constexpr const char *kRunFileNames[] = {
    "scene.toml",         "timeseries.csv",      "trajectory.h5",  "summary.json",
    "angular.json",       "frank.json",          "analysis.json",  "checkpoint.h5",
    "checkpoint.prev.h5", "order_parameter.png", "frank_cuts.png", "frank_surfaces.png",
    "angular.png",        "render.png"};

}  // namespace

bool same_file(const fs::path &a, const fs::path &b) {
  std::error_code ec;
  return fs::equivalent(a, b, ec) && !ec;
}

bool is_run_file_name(const std::string &name) {
  std::string base = name;
  if (base.size() > 4 && base.ends_with(".tmp")) base.resize(base.size() - 4);
  for (const char *known : kRunFileNames)
    if (base == known) return true;
  // A trajectory that a resume could not reopen, kept as trajectory.h5.before-step-N.
  constexpr std::string_view kAside = "trajectory.h5.before-step-";
  return base.size() > kAside.size() && base.starts_with(kAside) &&
         base.find_first_not_of("0123456789", kAside.size()) == std::string::npos;
}

std::vector<std::string> remove_run_files(const fs::path &dir) {
  std::vector<std::string> removed;
  std::error_code ec;
  for (const fs::directory_entry &e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!is_run_file_name(name) || e.is_directory(ec)) continue;
    if (!fs::remove(e.path(), ec) || ec)
      throw SceneError({fmt::format("--force: cannot remove the earlier run's {} ({})",
                                    e.path().string(), ec ? ec.message() : "not removed")});
    removed.push_back(name);
  }
  if (ec)
    throw SceneError({fmt::format("--force: cannot list {} ({})", dir.string(), ec.message())});
  std::sort(removed.begin(), removed.end());
  return removed;
}

void write_atomically(const fs::path &path, const std::string &text) {
  const fs::path tmp = path.string() + ".tmp";
  std::ofstream out(tmp);
  out << text;
  out.close();  // a full disk shows only here: never rename a short file over a good one
  if (!out) {
    const int why = errno;
    std::error_code ec;
    fs::remove(tmp, ec);
    throw SceneError({fmt::format("cannot write {} ({})", tmp.string(),
                                  why ? std::strerror(why) : "write failed")});
  }
  fs::rename(tmp, path);
}

TimeSeries::TimeSeries(const fs::path &path, long long keep_bytes) : path_(path) {
  if (keep_bytes >= 0) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec || static_cast<long long>(size) < keep_bytes)
      fmt::print(stderr,
                 "hardrod: warning: {} has {} bytes, the checkpoint recorded {}; appending to "
                 "what is there\n",
                 path.string(), ec ? 0 : size, keep_bytes);
    else
      fs::resize_file(path, static_cast<std::uintmax_t>(keep_bytes));
    out_.open(path, std::ios::app);
  } else {
    out_.open(path);
    out_ << kHeader;
    out_.flush();
  }
  if (!out_) throw SceneError({fmt::format("cannot write {}", path.string())});
  bytes_ = static_cast<long long>(out_.tellp());
}

void TimeSeries::write(const Sample &s, double dt, double running) {
  out_ << fmt::format("{},{:.10g},{},{:.8f},{:.8f},{:.8f},{:.10g},{:.8f},{},{:.6g}\n", s.step,
                      static_cast<double>(s.step) * dt,
                      s.production ? "production" : "equilibration", s.order_parameter,
                      s.pressure_star, running, s.kinetic_energy, s.temperature, s.collisions,
                      s.max_depth);
  errno = 0;
  out_.flush();  // a killed run keeps every sample it took
  if (!out_) {
    const int why = errno;
    // The part of the row that reached the file goes: the file ends with a whole row.
    out_.close();
    std::error_code ec;
    fs::resize_file(path_, static_cast<std::uintmax_t>(bytes_), ec);
    throw std::runtime_error(fmt::format("{}: cannot write ({})", path_.string(),
                                         why ? std::strerror(why) : "write failed"));
  }
  bytes_ = static_cast<long long>(out_.tellp());
}

std::unique_ptr<TrajectoryWriter> reopen_trajectory(const fs::path &path, const Scene &scene,
                                                    long long frames, long long step) {
  try {
    return std::make_unique<TrajectoryWriter>(path.string(), scene, frames);
  } catch (const std::exception &e) {
    const fs::path aside = path.string() + fmt::format(".before-step-{}", step);
    std::error_code ec;
    fs::rename(path, aside, ec);
    fmt::print(stderr, "hardrod: warning: {}; kept it as {} and started a new trajectory\n",
               e.what(), aside.string());
    return std::make_unique<TrajectoryWriter>(path.string(), scene);
  }
}

namespace {

// A run's file is a regular file or not there: anything else (a directory, a FIFO) is refused.
void require_file_or_nothing(const fs::path &path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || st.type() == fs::file_type::not_found || st.type() == fs::file_type::regular) return;
  throw SceneError(
      {fmt::format("{}: not a regular file; move it away and resume again "
                   "(nothing was changed)",
                   path.string())});
}

// Room to start in: the files a run makes at once, and a margin so that closing them on a
// disk that fills later never fails (HDF5 cannot recover from a failed close).
void require_room(const fs::path &dir) {
  constexpr std::uintmax_t kStartBytes = 96u << 10;  // an empty H5MD file is ~50 KB
  std::error_code ec;
  const std::uintmax_t free = fs::space(dir, ec).available;
  if (!ec && free < kStartBytes)
    throw SceneError(
        {fmt::format("output.dir = \"{}\": {} bytes free on its disk (No space left on device), "
                     "a run needs at least {} to start; nothing was written",
                     dir.string(), free, kStartBytes)});
}

void report_removed(const fs::path &dir, const std::vector<std::string> &removed) {
  if (removed.empty()) return;
  fmt::print(stderr, "hardrod: --force: removed the earlier run's {} from {}\n",
             fmt::join(removed, ", "), dir.string());
}

}  // namespace

RunFiles open_run_files(Communicator &comm, const fs::path &dir, const Scene &scene, bool force,
                        const RunState *resumed, long long step) {
  RunFiles files;
  std::string problem;
  if (comm.is_root()) {
    try {
      if (resumed) {
        files.lock = std::make_unique<RunLock>(dir);
        // Every file checked before any is changed, and scene.toml (which names the run)
        // rewritten last: a resume that fails leaves the directory as it was.
        for (const char *name : {"scene.toml", "timeseries.csv", "trajectory.h5"})
          require_file_or_nothing(dir / name);
        require_room(dir);
        files.series =
            std::make_unique<TimeSeries>(dir / "timeseries.csv", resumed->timeseries_bytes);
        files.trajectory =
            reopen_trajectory(dir / "trajectory.h5", scene, resumed->trajectory_frames, step);
        write_atomically(dir / "scene.toml", scene_to_toml(scene));
      } else {
        prepare_output_dir(dir, force);
        files.lock = std::make_unique<RunLock>(dir);
        // Under the lock: a run that still writes there keeps its files.
        if (force) report_removed(dir, remove_run_files(dir));
        require_room(dir);
        write_atomically(dir / "scene.toml", scene_to_toml(scene));
        files.series = std::make_unique<TimeSeries>(dir / "timeseries.csv", -1);
        files.trajectory =
            std::make_unique<TrajectoryWriter>((dir / "trajectory.h5").string(), scene);
      }
    } catch (const SceneError &e) {
      problem = e.problems().front();
    } catch (const std::exception &e) {
      problem = e.what();
    }
  }
  if (comm.sum("setup", problem.empty() ? 0LL : 1LL) > 0)
    throw SceneError(
        {comm.is_root() ? problem : "output directory could not be prepared (rank 0)"});
  return files;
}

void write_angular(const fs::path &dir, const AngularCounts &angular) {
  if (angular.total <= 0) return;
  nlohmann::json a;
  a["bins"] = kAngularBins;
  a["description"] =
      "distribution of |cos theta| between axes and the director over production samples, "
      "normalised so that the isotropic distribution is 1 in every bin";
  a["normalised"] = angular.normalised();
  a["total"] = angular.total;
  write_atomically(dir / "angular.json", a.dump(1) + "\n");
}

}  // namespace hardrod
