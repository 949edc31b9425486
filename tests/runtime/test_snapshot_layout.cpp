// The H5MD layout (runtime/snapshot.hpp): a time-dependent box read per frame, wrapped
// positions with image counts that give the unwrapped ones back, and files of the layout
// before it (a fixed box/edges[3], no /particles/wrapped) still read and still resumed.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "runtime/snapshot.hpp"
#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

struct SnapshotLayout : ::testing::Test {
  fs::path dir;
  Scene scene = testing::small_nematic(1e-3);
  Particles last;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("hardrod-snapshot-layout-" +
           std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  // Two frames, the second after 300 steps with two centres moved whole boxes away, as
  // unwrapped positions are after a long run.
  std::string write_run() {
    System sim(scene);
    const std::string path = (dir / "run.h5").string();
    TrajectoryWriter w(path, scene);
    w.append(sim.gather_bodies(), 0, 0.0);
    for (int k = 0; k < 300; ++k) sim.step();
    last = sim.gather_bodies();
    last.x[0] += 2 * scene.box.length.x;  // unwrapped centres two and one boxes away
    last.y[1] -= scene.box.length.y;
    w.append(last, sim.current_step(), sim.time());
    return path;
  }

  template <typename T>
  static std::vector<T> read(const std::string &path, const char *name, hid_t type) {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t set = H5Dopen2(f, name, H5P_DEFAULT);
    const hid_t space = H5Dget_space(set);
    std::vector<T> out(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
    H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
    H5Sclose(space);
    H5Dclose(set);
    H5Fclose(f);
    return out;
  }

  // Rewrites the file in the layout from before the time-dependent box.
  static void make_old_layout(const std::string &path, const Box &box) {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    H5Ldelete(f, "/particles/all/box/edges", H5P_DEFAULT);
    H5Ldelete(f, "/particles/wrapped", H5P_DEFAULT);
    const hsize_t three = 3;
    const hid_t space = H5Screate_simple(1, &three, nullptr);
    const hid_t set = H5Dcreate2(f, "/particles/all/box/edges", H5T_NATIVE_DOUBLE, space,
                                 H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const double edges[3] = {box.length.x, box.length.y, box.length.z};
    H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, edges);
    H5Dclose(set);
    H5Sclose(space);
    H5Fclose(f);
  }
};

TEST_F(SnapshotLayout, WrappedPositionsAndImagesGiveTheUnwrappedOnes) {
  const std::string path = write_run();
  const auto x = read<double>(path, "/particles/all/position/value", H5T_NATIVE_DOUBLE);
  const auto w = read<double>(path, "/particles/wrapped/position/value", H5T_NATIVE_DOUBLE);
  const auto image = read<int>(path, "/particles/wrapped/image/value", H5T_NATIVE_INT);
  ASSERT_EQ(x.size(), 2 * 3 * last.size());
  ASSERT_EQ(w.size(), x.size());
  const double l = scene.box.length.x;
  int outside = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    EXPECT_GE(w[k], 0.0);
    EXPECT_LT(w[k], l);
    EXPECT_NEAR(w[k] + image[k] * l, x[k], 1e-12) << k;
    outside += image[k] != 0;
  }
  EXPECT_GT(outside, 0);  // the test sees centres outside the box
  const auto edges = read<double>(path, "/particles/all/box/edges/value", H5T_NATIVE_DOUBLE);
  ASSERT_EQ(edges.size(), 18u);
  EXPECT_EQ(edges[9], l);
  EXPECT_EQ(edges[10], 0.0);
  const auto steps = read<long long>(path, "/particles/all/box/edges/step", H5T_NATIVE_LLONG);
  EXPECT_EQ(steps, (std::vector<long long>{0, 300}));
}

TEST_F(SnapshotLayout, TheBoxIsReadPerFrame) {
  const std::string path = write_run();
  {  // frame 0 with another (diagonal) box
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t set = H5Dopen2(f, "/particles/all/box/edges/value", H5P_DEFAULT);
    auto v = read<double>(path, "/particles/all/box/edges/value", H5T_NATIVE_DOUBLE);
    v[0] = 20.0;
    H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(set);
    H5Fclose(f);
  }
  EXPECT_EQ(read_h5md_frame(path, 0).box.length.x, 20.0);
  EXPECT_EQ(read_h5md_frame(path, 1).box.length.x, scene.box.length.x);
  {  // a sheared box: hardrod runs rectangular boxes only
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t set = H5Dopen2(f, "/particles/all/box/edges/value", H5P_DEFAULT);
    auto v = read<double>(path, "/particles/all/box/edges/value", H5T_NATIVE_DOUBLE);
    v[9 + 1] = 0.5;
    H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(set);
    H5Fclose(f);
  }
  try {
    read_h5md_frame(path, 1);
    FAIL() << "a sheared box was accepted";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("/particles/all/box/edges/value: edge 0 has component "
                                         "0.5 along axis 1; hardrod's boxes are rectangular"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(SnapshotLayout, OlderFilesAreStillReadAndResumedInTheirLayout) {
  const std::string path = write_run();
  make_old_layout(path, scene.box);
  const SnapshotFrame f = read_h5md_frame(path, -1);
  EXPECT_EQ(f.box.length.y, scene.box.length.y);
  EXPECT_EQ(f.step, 300);
  for (std::size_t i = 0; i < last.size(); ++i) ASSERT_EQ(f.bodies.x[i], last.x[i]) << i;
  {  // a resume cuts it back to one frame and appends in the old layout
    TrajectoryWriter w(path, scene, 1);
    w.append(last, 300, 0.3);
    EXPECT_EQ(w.frames(), 2);
  }
  const SnapshotFrame again = read_h5md_frame(path, -1);
  EXPECT_EQ(again.frames, 2);
  EXPECT_EQ(again.box.length.z, scene.box.length.z);
  // The new layout resumed likewise keeps its box and wrapped series in step.
  const std::string fresh = write_run();
  {
    TrajectoryWriter w(fresh, scene, 1);
    w.append(last, 300, 0.3);
  }
  EXPECT_EQ(read<double>(fresh, "/particles/all/box/edges/value", H5T_NATIVE_DOUBLE).size(), 18u);
  EXPECT_EQ(read<int>(fresh, "/particles/wrapped/image/value", H5T_NATIVE_INT).size(),
            2 * 3 * last.size());
  EXPECT_EQ(read_h5md_frame(fresh, -1).frames, 2);
}

}  // namespace
}  // namespace hardrod
