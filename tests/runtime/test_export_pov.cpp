// The POV-Ray export (runtime/export_pov.hpp): the colour scale's ends, the angle to the
// director, the rods of a written scene coloured by it (read back from the .pov text), the
// slab cut and its syntax.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "runtime/export_pov.hpp"

namespace hardrod {
namespace {

// Rods at the given centres and axes in a box of side 20 D.
SnapshotFrame frame_of(const std::vector<std::pair<Vec3, Vec3>> &rods) {
  SnapshotFrame f;
  f.box.length = {20.0, 20.0, 20.0};
  f.bodies.resize(rods.size());
  for (std::size_t i = 0; i < rods.size(); ++i) {
    f.bodies.id[i] = static_cast<std::int64_t>(i);
    f.bodies.set_position(i, rods[i].first);
    f.bodies.set_axis(i, rods[i].second);
  }
  f.frames = 1;
  return f;
}

// Along x, except the last rod, along y: the director is x.
SnapshotFrame nematic_with_one_across() {
  return frame_of({{{1, 1, 1}, {1, 0, 0}},
                   {{5, 5, 5}, {-1, 0, 0}},
                   {{9, 9, 9}, {1, 0, 0}},
                   {{13, 13, 13}, {0, 1, 0}}});
}

// The last argument of every rod's macro call R(x, y, z, ex, ey, ez, degree), in order.
std::vector<int> rod_degrees(const std::string &scene) {
  std::vector<int> out;
  std::istringstream lines(scene);
  for (std::string line; std::getline(lines, line);)
    if (line.starts_with("R(")) out.push_back(std::stoi(line.substr(line.rfind(',') + 1)));
  return out;
}

// The pigment of texture k of the Colour array, as written.
std::string texture_pigment(const std::string &scene, int k) {
  std::istringstream lines(scene);
  int seen = -1;
  bool in_array = false;
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with("#declare Colour = array[91]")) in_array = true;
    if (in_array && line.find("texture {") != std::string::npos && ++seen == k) {
      const std::size_t at = line.find("srgb");
      return line.substr(at, line.find('>', at) - at + 1);
    }
  }
  return "";
}

TEST(ExportPov, ScaleRunsFromBlueAlongTheDirectorToRedAcrossIt) {
  const Rgb parallel = angle_colour(0.0), across = angle_colour(90.0);
  EXPECT_DOUBLE_EQ(parallel.red, 0.19);
  EXPECT_DOUBLE_EQ(parallel.green, 0.27);
  EXPECT_DOUBLE_EQ(parallel.blue, 0.80);
  EXPECT_DOUBLE_EQ(across.red, 0.85);
  EXPECT_DOUBLE_EQ(across.green, 0.15);
  EXPECT_DOUBLE_EQ(across.blue, 0.12);
  EXPECT_DOUBLE_EQ(angle_colour(-5.0).blue, parallel.blue);  // clamped
  EXPECT_DOUBLE_EQ(angle_colour(120.0).red, across.red);
  const Rgb middle = angle_colour(45.0);  // a stop: green
  EXPECT_GT(middle.green, middle.red);
  EXPECT_GT(middle.green, middle.blue);
}

TEST(ExportPov, AngleToDirectorIgnoresTheRodsSense) {
  const Vec3 n{0.0, 0.0, 1.0};
  EXPECT_DOUBLE_EQ(angle_to_director({0, 0, 1}, n), 0.0);
  EXPECT_DOUBLE_EQ(angle_to_director({0, 0, -1}, n), 0.0);
  EXPECT_NEAR(angle_to_director({1, 0, 0}, n), 90.0, 1e-12);
  EXPECT_NEAR(angle_to_director({0, std::sqrt(0.5), -std::sqrt(0.5)}, n), 45.0, 1e-12);
  EXPECT_DOUBLE_EQ(angle_to_director({0, 0, 1.0 + 1e-15}, n), 0.0);  // no NaN past 1
}

TEST(ExportPov, RodAlongTheDirectorAndOneAcrossGetTheScalesEnds) {
  const std::string scene = pov_scene(nematic_with_one_across(), Shape{}, std::nullopt, "test");
  EXPECT_EQ(rod_degrees(scene), (std::vector<int>{0, 0, 0, 90}));
  EXPECT_EQ(texture_pigment(scene, 0), "srgb <0.1900, 0.2700, 0.8000>");
  EXPECT_EQ(texture_pigment(scene, 90), "srgb <0.8500, 0.1500, 0.1200>");
  // The legend's colour map starts and ends with the same colours.
  EXPECT_NE(scene.find("[0.0000 srgb <0.1900, 0.2700, 0.8000>]"), std::string::npos);
  EXPECT_NE(scene.find("[1.0000 srgb <0.8500, 0.1500, 0.1200>]"), std::string::npos);
  EXPECT_NE(scene.find("#macro R(X, Y, Z, EX, EY, EZ, K)"), std::string::npos);
  EXPECT_NE(scene.find("camera {"), std::string::npos);
  EXPECT_EQ(scene.find("#include"), std::string::npos);  // Debian's povray has no includes
}

TEST(ExportPov, SlabKeepsTheRodsWhoseFoldedCentresLieInIt) {
  SnapshotFrame f = nematic_with_one_across();
  f.bodies.set_position(0, {1.0 + 40.0, 1.0, 1.0});  // unwrapped: folds to x = 1
  const std::string scene = pov_scene(f, Shape{}, PovSlab{0, 0.0, 10.0}, "test");
  EXPECT_EQ(rod_degrees(scene), (std::vector<int>{0, 0, 0}));
  EXPECT_NE(scene.find("3 of 4 rods (centres with x in [0, 10) D)"), std::string::npos);
  EXPECT_EQ(rod_degrees(pov_scene(f, Shape{}, PovSlab{2, 12.0, 14.0}, "test")),
            (std::vector<int>{90}));
  EXPECT_THROW(pov_scene(f, Shape{}, PovSlab{1, 30.0, 40.0}, "test"), std::invalid_argument);
}

TEST(ExportPov, SpheresAreSpheres) {
  Shape sphere;
  sphere.length = 0.0;
  const std::string scene = pov_scene(nematic_with_one_across(), sphere, std::nullopt, "test");
  EXPECT_NE(scene.find("sphere { <X, Y, Z>, Radius"), std::string::npos);
  EXPECT_EQ(scene.find("cylinder { C - H"), std::string::npos);  // no zero-length cylinder
}

TEST(ExportPov, SlabSyntax) {
  const PovSlab s = parse_slab("y:-2.5:10");
  EXPECT_EQ(s.axis, 1);
  EXPECT_DOUBLE_EQ(s.from, -2.5);
  EXPECT_DOUBLE_EQ(s.to, 10.0);
  EXPECT_EQ(parse_slab("z:0:1e1").axis, 2);
  for (const char *bad : {"", "x", "x:0", "x:0:10:20", "w:0:10", "x:a:10", "x:0:10b", "x:5:5",
                          "x:10:0", "x:0:inf", "X:0:10"}) {
    try {
      parse_slab(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument &e) {
      EXPECT_NE(std::string(e.what()).find(std::string("--slab ") + bad), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace hardrod
