// The run directory's files as the run writes them (see run_files.hpp).
#include "runtime/run_files.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>

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

TimeSeries::TimeSeries(const fs::path &path, long long keep_bytes) {
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
}

void TimeSeries::write(const Sample &s, double dt, double running) {
  out_ << fmt::format("{},{:.10g},{},{:.8f},{:.8f},{:.8f},{:.10g},{:.8f},{},{:.6g}\n", s.step,
                      static_cast<double>(s.step) * dt,
                      s.production ? "production" : "equilibration", s.order_parameter,
                      s.pressure_star, running, s.kinetic_energy, s.temperature, s.collisions,
                      s.max_depth);
  out_.flush();  // a killed run keeps every sample it took
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

RunFiles open_run_files(Communicator &comm, const fs::path &dir, const Scene &scene, bool force,
                        const RunState *resumed, long long step) {
  RunFiles files;
  std::string problem;
  if (comm.is_root()) {
    try {
      if (resumed) {
        files.lock = std::make_unique<RunLock>(dir);
        write_atomically(dir / "scene.toml", scene_to_toml(scene));
        files.series =
            std::make_unique<TimeSeries>(dir / "timeseries.csv", resumed->timeseries_bytes);
        files.trajectory =
            reopen_trajectory(dir / "trajectory.h5", scene, resumed->trajectory_frames, step);
      } else {
        prepare_output_dir(dir, force);
        files.lock = std::make_unique<RunLock>(dir);
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
