// HOOMD's GSD schema (runtime/hoomd_gsd.hpp): the rotations and angular momenta against their
// definitions, the wrap into HOOMD's box, the GSD file layer written and read back, and a run
// started from an exported GSD frame against the H5MD start of the same frame.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "runtime/export.hpp"
#include "runtime/gsd_reader.hpp"
#include "runtime/hoomd_gsd.hpp"
#include "runtime/snapshot.hpp"
#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

// Unit axes spread over the sphere, with the poles and the points next to -z.
std::vector<Vec3> test_axes() {
  std::vector<Vec3> axes = {{0, 0, 1},     {0, 0, -1},        {1, 0, 0},      {0, -1, 0},
                            {1e-9, 0, -1}, {3e-8, -4e-8, -1}, {1e-200, 0, -1}};
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  for (int k = 0; k < 1000; ++k) axes.push_back({g(rng), g(rng), g(rng)});
  for (Vec3 &e : axes) e = (1.0 / norm(e)) * e;
  return axes;
}

TEST(HoomdGsd, QuaternionTurnsZOntoTheAxisAndBack) {
  for (const Vec3 &e : test_axes()) {
    const Quaternion q = quaternion_from_axis(e);
    EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-15);
    EXPECT_GE(q[0], 0.0);  // the shorter turn
    const Vec3 back = axis_from_quaternion(q);
    EXPECT_NEAR(norm(back - e), 0.0, 2e-15) << e.x << " " << e.y << " " << e.z;
  }
}

TEST(HoomdGsd, AngularMomentumIsHoomdsQuaternionAndComesBack) {
  const double inertia = 2.5;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  for (const Vec3 &e : test_axes()) {
    Vec3 w{g(rng), g(rng), g(rng)};
    w = w - dot(w, e) * e;
    const Quaternion q = quaternion_from_axis(e);
    const Quaternion p = angmom_from_angular_velocity(q, w, inertia);
    // HOOMD: S_body = 1/2 Im(q* P) is I w in body coordinates, with no part along body z.
    const Quaternion qc{q[0], -q[1], -q[2], -q[3]};
    const Vec3 s{0.5 * (qc[0] * p[1] + qc[1] * p[0] + qc[2] * p[3] - qc[3] * p[2]),
                 0.5 * (qc[0] * p[2] - qc[1] * p[3] + qc[2] * p[0] + qc[3] * p[1]),
                 0.5 * (qc[0] * p[3] + qc[1] * p[2] - qc[2] * p[1] + qc[3] * p[0])};
    EXPECT_NEAR(s.z, 0.0, 1e-12);
    EXPECT_NEAR(norm(s), inertia * norm(w), 1e-12);
    const Vec3 back = angular_velocity_from_angmom(q, p, {inertia, inertia, 0.0});
    EXPECT_NEAR(norm(back - w), 0.0, 1e-14 * (1 + norm(w)));
  }
}

TEST(HoomdGsd, WrapIsInsideHoomdsFloatBoxAndCountsImages) {
  const double side = 28.525578;
  const float half = 0.5f * static_cast<float>(side);
  for (double u : {0.0, 1.0, -1.0, 0.5 * side, -0.5 * side, std::nextafter(0.5 * side, 0.0), side,
                   -side, 3.7 * side + 0.1, -12.25 * side, 1e6, -1e6}) {
    const Wrapped w = wrap_for_hoomd(u, side);
    EXPECT_GE(w.position, -half) << u;
    EXPECT_LT(w.position, half) << u;
    EXPECT_NEAR(w.position + w.image * side, u, 1e-6 * (1 + std::fabs(u) / side)) << u;
  }
  // The upper edge rounds, in float, to L/2: it becomes -L/2 of the next image.
  const Wrapped edge = wrap_for_hoomd(std::nextafter(0.5 * side, 0.0), side);
  EXPECT_EQ(edge.image, 1);
  EXPECT_EQ(edge.position, -half);
}

TEST(HoomdGsd, ShapesAreHoomdsJson) {
  Shape rod;
  rod.length = 5.0;
  EXPECT_EQ(hoomd_shape_json(rod),
            "{\"type\": \"ConvexPolyhedron\", \"rounding_radius\": 0.5, \"vertices\": "
            "[[0, 0, -2.5], [0, 0, 2.5]]}");
  Shape sphere;
  sphere.length = 0.0;
  EXPECT_EQ(hoomd_shape_json(sphere), "{\"type\": \"Sphere\", \"diameter\": 1}");
}

struct GsdFiles : ::testing::Test {
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("hardrod-gsd-" +
           std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  // Two frames of a short run of the small nematic: the lattice and 300 steps later.
  std::string write_run(const Scene &scene) {
    System sim(scene);
    const std::string path = (dir / "run.h5").string();
    TrajectoryWriter w(path, scene);
    w.append(sim.gather_bodies(), 0, 0.0);
    for (int k = 0; k < 300; ++k) sim.step();
    w.append(sim.gather_bodies(), sim.current_step(), sim.time());
    return path;
  }
};

TEST_F(GsdFiles, LayerWrittenIsReadBackWithFrameZeroAsDefault) {
  const std::string path = (dir / "layer.gsd").string();
  {
    gsd::Writer w(path, "test", "hoomd", gsd::make_version(1, 4));
    w.write_chunk("b", std::vector<float>{1.5f, 2.5f, 3.5f, 4.5f}, 2);
    w.write_chunk("a", std::vector<std::uint64_t>{7}, 1);
    w.end_frame();
    w.write_chunk("a", std::vector<std::uint64_t>{8}, 1);
    w.end_frame();
    w.finish();
  }
  const gsd::Reader r(path);
  EXPECT_EQ(r.frames(), 2u);
  EXPECT_EQ(r.schema(), "hoomd");
  EXPECT_EQ(r.schema_version(), gsd::make_version(1, 4));
  ASSERT_NE(r.find(0, "b"), nullptr);
  EXPECT_EQ(r.find(1, "b"), nullptr);
  EXPECT_EQ(r.find(0, "c"), nullptr);
  EXPECT_EQ(r.read<double>(*r.find(0, "b")), (std::vector<double>{1.5, 2.5, 3.5, 4.5}));
  EXPECT_EQ(r.read<double>(*r.find(1, "a")), std::vector<double>{8});
  // A file cut short, or one that is not GSD, is refused with its name.
  fs::copy_file(path, dir / "cut.gsd");
  fs::resize_file(dir / "cut.gsd", fs::file_size(path) - 40);
  for (const char *bad : {"cut.gsd", "none.gsd"}) {
    if (std::string(bad) == "none.gsd") std::ofstream(dir / bad) << std::string(300, 'x');
    try {
      gsd::Reader((dir / bad).string());
      FAIL() << bad;
    } catch (const std::runtime_error &e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
}

TEST_F(GsdFiles, RunStartsFromAnExportedFrameAsFromTheH5mdFrame) {
  Scene scene = testing::small_nematic(1e-3);
  const std::string h5 = write_run(scene);
  const std::string gsd = (dir / "run.gsd").string();
  export_trajectory(h5, std::nullopt, gsd, ExportFormat::kGsd);
  EXPECT_FALSE(fs::exists(gsd + ".tmp"));
  const SnapshotFrame last = read_h5md_frame_with_velocities(h5, -1);
  scene.configuration = Configuration::kFile;
  scene.init_file = gsd;
  const Particles from_gsd = initial_bodies(scene);
  scene.init_file = h5;
  const Particles from_h5md = initial_bodies(scene);
  ASSERT_EQ(from_gsd.size(), from_h5md.size());
  const double half = 0.5 * scene.box.length.x, ulp = std::ldexp(1.0, -24) * half;
  double dx = 0, de = 0, dv = 0, dw = 0;
  for (std::size_t i = 0; i < from_gsd.size(); ++i) {
    dx = std::max(dx, norm(from_gsd.position(i) - from_h5md.position(i)));
    de = std::max(de, norm(from_gsd.axis(i) - from_h5md.axis(i)));
    dv = std::max(dv, norm(from_gsd.velocity(i) - last.bodies.velocity(i)) /
                          (1e-300 + norm(last.bodies.velocity(i))));
    dw = std::max(dw, norm(from_gsd.angular_velocity(i) - last.bodies.angular_velocity(i)) /
                          (1e-300 + norm(last.bodies.angular_velocity(i))));
    EXPECT_NEAR(dot(from_gsd.axis(i), from_gsd.angular_velocity(i)), 0.0, 1e-12);
  }
  // Positions: the file's float, within half a float ulp of |x| <= L/2 (and the double sum).
  EXPECT_LE(dx, std::sqrt(3.0) * ulp * 1.01);
  EXPECT_LT(de, 3e-7);  // float quaternions
  EXPECT_LT(dv, 3e-7);  // float velocities, the file's rather than fresh ones
  EXPECT_LT(dw, 1e-6);  // float angular momenta and quaternions
  std::printf(
      "GSD start vs H5MD: |dx| %.3g (bound 2^-24 L/2 = %.3g), |de| %.3g, dv/v %.3g, "
      "dw/w %.3g\n",
      dx, ulp, de, dv, dw);
  // Frame 0 is the lattice with its velocities; a run starts from it and goes on.
  scene.init_file = gsd;
  scene.init_frame = 0;
  System sim(scene);
  for (int k = 0; k < 20; ++k) sim.step();
  EXPECT_EQ(sim.current_step(), 20);
}

TEST_F(GsdFiles, StartRefusesAFrameThatDoesNotFitTheSceneNamingFileAndValue) {
  Scene scene = testing::small_nematic(1e-3);
  const std::string h5 = write_run(scene);
  const std::string gsd = (dir / "run.gsd").string();
  export_trajectory(h5, -1, gsd, ExportFormat::kGsd);
  scene.configuration = Configuration::kFile;
  scene.init_file = gsd;
  Scene more = scene;
  more.n = 300;
  EXPECT_NE(testing::start_error(more).find("holds 288 bodies, system.n = 300"), std::string::npos)
      << testing::start_error(more);
  Scene wider = scene;
  wider.box.length.x *= 1.0 + 1e-6;
  EXPECT_NE(testing::start_error(wider).find("the scene's is"), std::string::npos)
      << testing::start_error(wider);
  EXPECT_NE(testing::start_error(wider).find("init.file = \"" + gsd + "\""), std::string::npos);
  Scene later = scene;
  later.init_frame = 1;  // one frame exported
  EXPECT_NE(testing::start_error(later).find("frame 1 requested, the file has 1 frame(s)"),
            std::string::npos)
      << testing::start_error(later);
  // A tilted box, and a quaternion of zeros.
  for (const char *what : {"tilt", "zero"}) {
    const std::string bad = (dir / (std::string(what) + ".gsd")).string();
    gsd::Writer w(bad, "test", "hoomd", gsd::make_version(1, 4));
    const float l = static_cast<float>(scene.box.length.x);
    w.write_chunk("configuration/box",
                  std::vector<float>{l, l, l, std::string(what) == "tilt" ? 0.1f : 0.0f, 0, 0}, 1);
    w.write_chunk("particles/N", std::vector<std::uint32_t>{288}, 1);
    w.write_chunk("particles/position", std::vector<float>(3 * 288, 0.0f), 3);
    w.write_chunk("particles/orientation", std::vector<float>(4 * 288, 0.0f), 4);
    w.end_frame();
    w.finish();
    Scene s = scene;
    s.init_file = bad;
    EXPECT_NE(
        testing::start_error(s).find(std::string(what) == "tilt" ? "tilts xy = 0.1" : "is zero"),
        std::string::npos)
        << testing::start_error(s);
  }
}

TEST_F(GsdFiles, AChunkMissingFromTheFrameIsFrameZerosThenTheDefault) {
  Scene scene = testing::small_nematic(1e-3);
  const std::string path = (dir / "two.gsd").string();
  const float l = static_cast<float>(scene.box.length.x);
  const Quaternion q = quaternion_from_axis({0.6, 0.0, 0.8});
  {
    gsd::Writer w(path, "test", "hoomd", gsd::make_version(1, 4));
    std::vector<float> position(3 * 288);
    for (std::size_t i = 0; i < 288; ++i) position[3 * i] = -0.5f * l + 0.04f * i;
    std::vector<float> orientation;
    for (std::size_t i = 0; i < 288; ++i) orientation.insert(orientation.end(), q.begin(), q.end());
    w.write_chunk("configuration/box", std::vector<float>{l, l, l, 0, 0, 0}, 1);
    w.write_chunk("particles/N", std::vector<std::uint32_t>{288}, 1);
    w.write_chunk("particles/position", position, 3);
    w.write_chunk("particles/orientation", orientation, 4);
    w.end_frame();
    w.write_chunk("configuration/step", std::vector<std::uint64_t>{500}, 1);
    w.write_chunk("particles/image", std::vector<std::int32_t>(3 * 288, 2), 3);
    w.end_frame();
    // Fewer particles: frame 0's orientations do not fit, the default (1, 0, 0, 0) holds.
    w.write_chunk("particles/N", std::vector<std::uint32_t>{100}, 1);
    w.write_chunk("particles/position", std::vector<float>(3 * 100, 1.0f), 3);
    w.end_frame();
    w.finish();
  }
  const GsdFrame f = read_gsd_frame(path, 1, scene.shape);
  EXPECT_EQ(f.frame, 1);
  EXPECT_EQ(f.step, 500);
  EXPECT_FALSE(f.has_velocities);
  EXPECT_NEAR(f.bodies.x[10], -0.5 * l + 0.4, 1e-6);  // frame 0's positions
  EXPECT_EQ(f.image[10][1], 2);
  EXPECT_NEAR(norm(f.bodies.axis(7) - Vec3{0.6, 0.0, 0.8}), 0.0, 1e-7);  // frame 0's axes
  const GsdFrame first = read_gsd_frame(path, 0, scene.shape);
  EXPECT_EQ(first.step, 0);  // the schema's default
  EXPECT_EQ(first.image[10][1], 0);
  const GsdFrame fewer = read_gsd_frame(path, -1, scene.shape);
  ASSERT_EQ(fewer.bodies.size(), 100u);
  EXPECT_EQ(fewer.bodies.axis(99).z, 1.0);
}

TEST_F(GsdFiles, ExtendedXyzHasEveryFrameTheBoxAndOvitosQuaternions) {
  Scene scene = testing::small_nematic(1e-3);
  const std::string h5 = write_run(scene);
  const std::string xyz = (dir / "run.xyz").string();
  export_trajectory(h5, std::nullopt, xyz, ExportFormat::kXyz);
  std::ifstream in(xyz);
  const SnapshotFrame last = read_h5md_frame(h5, -1);
  std::string line;
  int frames = 0;
  while (std::getline(in, line)) {
    EXPECT_EQ(line, "288");
    std::getline(in, line);
    EXPECT_NE(line.find("Lattice=\""), std::string::npos) << line;
    EXPECT_NE(line.find("pbc=\"T T T\""), std::string::npos) << line;
    EXPECT_NE(
        line.find("Properties=species:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:id:I:1"),
        std::string::npos)
        << line;
    EXPECT_NE(line.find(frames == 0 ? "step=0" : "step=300"), std::string::npos) << line;
    for (std::size_t i = 0; i < 288; ++i) {
      ASSERT_TRUE(std::getline(in, line));
      std::istringstream row(line);
      std::string species;
      double x[3], q[4], shape[3];
      long long id;
      ASSERT_TRUE(row >> species >> x[0] >> x[1] >> x[2] >> q[0] >> q[1] >> q[2] >> q[3] >>
                  shape[0] >> shape[1] >> shape[2] >> id)
          << line;
      EXPECT_EQ(species, "X");
      EXPECT_EQ(id, static_cast<long long>(i));
      for (double c : x) {
        EXPECT_GE(c, 0.0);
        EXPECT_LT(c, scene.box.length.x);
      }
      EXPECT_EQ(shape[0], 0.5);
      EXPECT_EQ(shape[2], 5.0);
      if (frames == 1) {  // OVITO's (x, y, z, w) turns z onto the axis
        const Vec3 e = axis_from_quaternion({q[3], q[0], q[1], q[2]});
        EXPECT_NEAR(norm(e - last.bodies.axis(i)), 0.0, 1e-11);
      }
    }
    ++frames;
  }
  EXPECT_EQ(frames, 2);
  // --frame: only that one; --format from the extension; a bad export keeps the old file.
  EXPECT_EQ(choose_export_format("", "a.gsd"), ExportFormat::kGsd);
  EXPECT_EQ(choose_export_format("", "a"), ExportFormat::kXyz);
  EXPECT_EQ(choose_export_format("xyz", "a.gsd"), ExportFormat::kXyz);
  EXPECT_THROW(choose_export_format("pdb", ""), std::invalid_argument);
  const auto size = fs::file_size(xyz);
  EXPECT_THROW(export_trajectory(h5, 5, xyz, ExportFormat::kXyz), std::runtime_error);
  EXPECT_EQ(fs::file_size(xyz), size);
  EXPECT_FALSE(fs::exists(xyz + ".tmp"));
}

}  // namespace
}  // namespace hardrod
