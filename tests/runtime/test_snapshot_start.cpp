// Starting a run from a snapshot (init.configuration = "file"): the frame's positions and
// axes, bit for bit, and a clear SceneError for every file that does not fit the scene.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "runtime/scene.hpp"
#include "runtime/snapshot.hpp"
#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

struct SnapshotStart : ::testing::Test {
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("hardrod-snapshot-start-" +
           std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  // Two frames of a short run of the small nematic: the lattice and 200 steps later.
  std::string write_run(Particles *last) {
    Scene scene = testing::small_nematic(1e-3);
    System sim(scene);
    const std::string path = (dir / "run.h5").string();
    TrajectoryWriter w(path, scene);
    w.append(sim.gather_bodies(), 0, 0.0);
    for (int k = 0; k < 200; ++k) sim.step();
    *last = sim.gather_bodies();
    w.append(*last, sim.current_step(), sim.time());
    return path;
  }

  // The small nematic started from the last frame of write_run.
  Scene file_start(Particles *last) {
    Scene scene = testing::small_nematic(1e-3);
    scene.configuration = Configuration::kFile;
    scene.init_file = write_run(last);
    scene.init_frame = -1;
    return scene;
  }
};

TEST_F(SnapshotStart, TakesPositionsAndAxesOfTheFrameBitForBit) {
  Particles last;
  Scene scene = file_start(&last);
  const Particles p = initial_bodies(scene);
  ASSERT_EQ(p.size(), last.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.id[i], static_cast<std::int64_t>(i));
    for (auto [a, b] : {std::pair{&p.x, &last.x},
                        {&p.y, &last.y},
                        {&p.z, &last.z},
                        {&p.ex, &last.ex},
                        {&p.ey, &last.ey},
                        {&p.ez, &last.ez}})
      ASSERT_EQ(std::memcmp(&(*a)[i], &(*b)[i], sizeof(double)), 0) << i;
  }
  // Velocities are fresh at the scene's temperature, not the file's.
  double ke = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) ke += norm2(p.velocity(i));
  EXPECT_GT(ke, 0.0);
  // Frame 0 is the lattice; a run can start from it and goes on.
  scene.init_frame = 0;
  System sim(scene);
  for (int k = 0; k < 20; ++k) sim.step();
  EXPECT_EQ(sim.current_step(), 20);
  // The scene names the file and the frame in canonical form.
  const std::string toml = scene_to_toml(scene);
  EXPECT_NE(toml.find("configuration = \"file\""), std::string::npos) << toml;
  EXPECT_EQ(parse_scene(toml).init_file, scene.init_file);
}

TEST_F(SnapshotStart, RejectsFilesThatDoNotFitWithTheKeyAndTheReason) {
  Particles last;
  Scene scene = file_start(&last);

  scene.init_frame = 2;
  EXPECT_NE(testing::start_error(scene).find("frame 2 requested, the file has 2 frame(s)"),
            std::string::npos)
      << testing::start_error(scene);
  scene.init_frame = -3;
  EXPECT_NE(testing::start_error(scene).find("the file has 2"), std::string::npos);
  scene.init_frame = -1;

  Scene other_n = scene;
  other_n.n = 287;
  EXPECT_NE(testing::start_error(other_n).find("holds 288 bodies, system.n = 287"),
            std::string::npos)
      << testing::start_error(other_n);

  Scene other_box = scene;
  other_box.box.length.y *= 1.01;
  EXPECT_NE(testing::start_error(other_box).find("the scene's is"), std::string::npos)
      << testing::start_error(other_box);

  Scene missing = scene;
  missing.init_file = (dir / "absent.h5").string();
  EXPECT_NE(testing::start_error(missing).find("init.file = \"" + missing.init_file + "\""),
            std::string::npos)
      << testing::start_error(missing);
  EXPECT_NE(testing::start_error(missing).find(": No such file or directory"), std::string::npos)
      << testing::start_error(missing);

  Scene garbage = scene;
  garbage.init_file = (dir / "garbage.h5").string();
  std::ofstream(garbage.init_file) << "not hdf5 at all";
  EXPECT_NE(testing::start_error(garbage).find("not an HDF5 file"), std::string::npos)
      << testing::start_error(garbage);
}

TEST_F(SnapshotStart, RejectsFramesWithBadBodiesOrNoFrame) {
  Particles last;
  Scene scene = file_start(&last);
  // NaN and a non-unit axis inside an otherwise valid file.
  Particles bad = last;
  bad.x[10] = std::nan("");
  {
    TrajectoryWriter w((dir / "nan.h5").string(), scene);
    w.append(bad, 0, 0.0);
  }
  Scene nan_file = scene;
  nan_file.init_file = (dir / "nan.h5").string();
  EXPECT_NE(testing::start_error(nan_file).find("body 10: position or axis not finite"),
            std::string::npos)
      << testing::start_error(nan_file);
  bad = last;
  bad.ey[3] += 0.1;
  {
    TrajectoryWriter w((dir / "axis.h5").string(), scene);
    w.append(bad, 0, 0.0);
  }
  Scene axis_file = scene;
  axis_file.init_file = (dir / "axis.h5").string();
  EXPECT_NE(testing::start_error(axis_file).find("body 3: axis has length"), std::string::npos)
      << testing::start_error(axis_file);
  // A trajectory with no frame at all.
  { TrajectoryWriter w((dir / "empty.h5").string(), scene); }
  Scene empty = scene;
  empty.init_file = (dir / "empty.h5").string();
  EXPECT_NE(testing::start_error(empty).find("the file has 0 frame(s)"), std::string::npos)
      << testing::start_error(empty);
}

// A frame whose bodies overlap is refused at the start, naming the pair and the depth, not
// run at step 1 into "try a smaller run.dt".
TEST_F(SnapshotStart, OverlappingFrameIsRefusedAtTheStart) {
  Particles last;
  Scene scene = file_start(&last);
  scene.init_frame = 0;
  EXPECT_EQ(testing::start_error(scene), "");  // the lattice touches nowhere
  // The same frame with one body moved half a diameter beside another.
  Particles bodies = System(scene).gather_bodies();
  bodies.x[7] = bodies.x[3];
  bodies.y[7] = bodies.y[3] + 0.5;
  bodies.z[7] = bodies.z[3];
  scene.init_file = (dir / "overlapping.h5").string();
  TrajectoryWriter(scene.init_file, scene).append(bodies, 0, 0.0);
  const std::string error = testing::start_error(scene);
  EXPECT_NE(error.find("frame 0: the start configuration overlaps: bodies "), std::string::npos)
      << error;
  EXPECT_NE(error.find("more than run.max_overlap = 0.05 D"), std::string::npos) << error;
}

TEST(SceneInit, ConfigurationKeysAreCheckedAndNamed) {
  const std::string base =
      "[system]\nn = 288\nreduced_density = 0.5\naspect_ratio = 5.0\n[run]\ndt = 1e-4\n"
      "steps = 10\n";
  try {
    parse_scene(base + "[init]\nconfiguration = \"random\"\n");
    FAIL();
  } catch (const SceneError &e) {
    EXPECT_NE(std::string(e.what()).find("init.configuration = \"random\""), std::string::npos)
        << e.what();
  }
  try {
    parse_scene(base + "[init]\nconfiguration = \"file\"\n");
    FAIL();
  } catch (const SceneError &e) {
    EXPECT_NE(std::string(e.what()).find("init.file"), std::string::npos) << e.what();
  }
  const Scene s = parse_scene(base + "[init]\nconfiguration = \"file\"\nfile = \"x.h5\"\n");
  EXPECT_EQ(s.configuration, Configuration::kFile);
  EXPECT_EQ(s.init_file, "x.h5");
  EXPECT_EQ(s.init_frame, -1);
}

TEST(SceneInit, IsotropicStartRunsAndRoundTrips) {
  const std::string text =
      "[system]\nn = 300\nreduced_density = 0.3\naspect_ratio = 5.0\n[init]\n"
      "configuration = \"isotropic\"\nseed = 4\n[run]\ndt = 1e-4\nsteps = 10\n";
  const Scene scene = parse_scene(text);
  EXPECT_EQ(scene.configuration, Configuration::kIsotropic);
  EXPECT_EQ(parse_scene(scene_to_toml(scene)).configuration, Configuration::kIsotropic);
  System sim(scene);
  EXPECT_LT(sim.order().S, 0.15);            // isotropic: ~1/sqrt(n)
  for (int k = 0; k < 100; ++k) sim.step();  // no overlap beyond run.max_overlap
  EXPECT_EQ(sim.current_step(), 100);
  // A density no isotropic packing reaches: a SceneError naming the key.
  Scene dense = scene;
  dense.box.length = dense.box.length * 0.5;
  try {
    initial_bodies(dense);
    FAIL();
  } catch (const SceneError &e) {
    EXPECT_NE(std::string(e.what()).find("init.configuration = \"isotropic\""), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hardrod
