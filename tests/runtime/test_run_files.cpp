// The run directory's files: a fresh run refuses a directory holding a run, the time series
// is cut back to a checkpoint's byte count on resume, writes go through a rename.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "runtime/run_files.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string &name) {
  const fs::path dir = fs::temp_directory_path() / ("hardrod-test-run-files-" + name);
  fs::remove_all(dir);
  return dir;
}

std::string read(const fs::path &path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(RunFiles, PrepareOutputDirRefusesAnEarlierRunUnlessForced) {
  const fs::path dir = fresh_dir("prepare");
  prepare_output_dir(dir, false);
  EXPECT_TRUE(fs::is_directory(dir));
  prepare_output_dir(dir, false);  // empty: fine
  std::ofstream(dir / "timeseries.csv") << "x";
  EXPECT_THROW(prepare_output_dir(dir, false), SceneError);
  EXPECT_NO_THROW(prepare_output_dir(dir, true));
  fs::remove_all(dir);
}

TEST(RunFiles, WriteAtomicallyLeavesNoTemporary) {
  const fs::path dir = fresh_dir("atomic");
  fs::create_directories(dir);
  write_atomically(dir / "a.json", "{}\n");
  EXPECT_EQ(read(dir / "a.json"), "{}\n");
  EXPECT_FALSE(fs::exists(dir / "a.json.tmp"));
  fs::remove_all(dir);
}

TEST(RunFiles, TimeSeriesIsCutBackToTheCheckpointsBytes) {
  const fs::path dir = fresh_dir("series");
  fs::create_directories(dir);
  const fs::path path = dir / "timeseries.csv";
  Sample s;
  s.step = 10;
  s.production = true;
  s.order_parameter = 0.5;
  long long kept = 0;
  {
    TimeSeries series(path, -1);
    series.write(s, 0.01, 1.0);
    kept = series.bytes();
    s.step = 20;
    series.write(s, 0.01, 1.0);  // after the checkpoint: dropped on resume
  }
  const std::string row = "10,0.1,production,0.50000000,0.00000000,1.00000000,0,0.00000000,0,0\n";
  EXPECT_EQ(read(path),
            std::string(TimeSeries::kHeader) + row +
                "20,0.2,production,0.50000000,0.00000000,1.00000000,0,0.00000000,0,0\n");
  {
    TimeSeries resumed(path, kept);
    EXPECT_EQ(resumed.bytes(), kept);
  }
  EXPECT_EQ(read(path), std::string(TimeSeries::kHeader) + row);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hardrod
