// Scene reader: derived boxes against docs/physics.md section 2, every problem reported together
// with key and value, overrides, the "auto" lattice, the canonical round trip, the shipped
// scene files, and a seeded mutation fuzz (parse or SceneError, never anything else).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "runtime/scene.hpp"
#include "tests/scene_problems.hpp"

namespace hardrod {
namespace {

const std::string kEveryday = R"(# everyday
[system]
shape = "spherocylinder"
aspect_ratio = 5.0
n = 2304
reduced_density = 0.5
[init]
lattice = [4, 24, 24]
axis = "x"
seed = 1
temperature = 1.0
[run]
dt = 1e-4
equilibration_steps = 100000
steps = 200000
thermostat_interval = 200
sample_interval = 1000
max_overlap = 0.05
solver_tolerance = 1e-10
solver_max_iterations = 1000
skin = 0.3
[output]
dir = "runs/everyday"
log_interval = 0
)";

const std::string kSpheres = R"(
[system]
shape = "sphere"
n = 2197
packing_fraction = 0.45
[init]
lattice = [13, 13, 13]
[run]
dt = 1e-4
steps = 100000
)";

// A minimal rod scene with the given [system] density line and [init] lattice line.
std::string rods(long long n, const std::string &density, const std::string &lattice,
                 const std::string &axis = "x") {
  return "[system]\nn = " + std::to_string(n) + "\n" + density + "\n[init]\n" + lattice +
         "\naxis = \"" + axis + "\"\n[run]\ndt = 1e-4\nsteps = 10\n";
}

using testing::contains;
using testing::lines;
using testing::problems_of;

bool same(const Scene &a, const Scene &b) {
  return a.shape_name == b.shape_name && a.shape.length == b.shape.length &&
         a.shape.diameter == b.shape.diameter && a.shape.mass == b.shape.mass && a.n == b.n &&
         a.box.length.x == b.box.length.x && a.box.length.y == b.box.length.y &&
         a.box.length.z == b.box.length.z && a.lattice == b.lattice && a.axis == b.axis &&
         a.seed == b.seed && a.temperature == b.temperature && a.dt == b.dt &&
         a.equilibration_steps == b.equilibration_steps && a.steps == b.steps &&
         a.thermostat_interval == b.thermostat_interval && a.sample_interval == b.sample_interval &&
         a.max_overlap == b.max_overlap && a.solver_tolerance == b.solver_tolerance &&
         a.solver_max_iterations == b.solver_max_iterations && a.skin == b.skin &&
         a.output_dir == b.output_dir && a.log_interval == b.log_interval &&
         a.snapshot_interval == b.snapshot_interval && a.frank == b.frank &&
         a.fourier_kmax == b.fourier_kmax && a.fourier_interval == b.fourier_interval;
}

TEST(Scene, ObservablesSection) {
  const std::string base =
      "[system]\nn = 2304\nreduced_density = 0.5\n[init]\nlattice = [4, 24, 24]\n"
      "[run]\ndt = 1e-4\nsteps = 10\n";
  const Scene off = parse_scene(base);
  EXPECT_FALSE(off.frank);  // nothing is paid for unless asked
  const Scene on = parse_scene(base +
                               "[observables]\nfrank = true\nfourier_kmax = 6\n"
                               "fourier_interval = 200\n");
  EXPECT_TRUE(on.frank);
  EXPECT_EQ(on.fourier_kmax, 6);
  // Unset, kmax follows the box: modes up to |k_a| ~ 1 / D (the fits' range), 6 in the everyday
  // 28.5 D box, 10 in the paper's 57 D box (N = 18432 at the same density).
  EXPECT_EQ(off.fourier_kmax, 6) << off.box.length.x;
  const Scene paper = parse_scene(
      "[system]\nn = 18432\nreduced_density = 0.5\n[init]\nlattice = [8, 48, 48]\n"
      "[run]\ndt = 1e-4\nsteps = 10\n");
  EXPECT_EQ(paper.fourier_kmax, 10) << paper.box.length.x;
  EXPECT_EQ(on.fourier_interval, 200);
  try {
    parse_scene(base + "[observables]\nfrank = \"yes\"\nfourier_kmax = 0\n");
    FAIL() << "bad observables accepted";
  } catch (const SceneError &e) {
    ASSERT_EQ(e.problems().size(), 2u) << e.what();
    EXPECT_NE(e.problems()[0].find("observables.frank = \"yes\""), std::string::npos) << e.what();
    EXPECT_NE(e.problems()[1].find("observables.fourier_kmax = 0"), std::string::npos) << e.what();
  }
}

// What every accepted scene guarantees to the rest of the program.
void expect_invariants(const Scene &s, const std::string &text) {
  const double range = 2.0 * s.shape.interaction_range();
  const double sides[3] = {s.box.length.x, s.box.length.y, s.box.length.z};
  EXPECT_TRUE(s.shape_name == "spherocylinder" || s.shape_name == "sphere") << text;
  EXPECT_TRUE(std::isfinite(s.shape.length) && s.shape.length >= 0.0) << text;
  EXPECT_GE(s.n, 1) << text;
  EXPECT_TRUE(std::isfinite(s.box.volume())) << text;
  for (const double side : sides) EXPECT_GT(side, range) << text;
  EXPECT_TRUE(s.axis >= 0 && s.axis <= 2) << text;
  long long product = 1;
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(s.lattice[k], 1) << text;
    product *= s.lattice[k];
    const double need = k == s.axis ? s.shape.interaction_range() : s.shape.diameter;
    EXPECT_GE(sides[k] / static_cast<double>(s.lattice[k]), need) << text;
  }
  EXPECT_EQ(product, s.n) << text;
  EXPECT_TRUE(std::isfinite(s.dt) && s.dt > 0.0) << text;
  EXPECT_TRUE(std::isfinite(s.temperature) && s.temperature > 0.0) << text;
  EXPECT_GE(s.steps, 0) << text;
  EXPECT_GE(s.equilibration_steps, 0) << text;
  EXPECT_GE(s.thermostat_interval, 0) << text;
  EXPECT_GE(s.sample_interval, 1) << text;
  EXPECT_TRUE(s.max_overlap > 0.0 && s.max_overlap < 0.5) << text;
  EXPECT_TRUE(s.solver_tolerance > 0.0 && s.solver_tolerance < 1.0) << text;
  EXPECT_GE(s.solver_max_iterations, 1) << text;
  EXPECT_TRUE(s.skin > 0.0 && s.skin <= 2.0) << text;
  EXPECT_FALSE(s.output_dir.empty()) << text;
  EXPECT_GE(s.log_interval, 0) << text;
}

TEST(Scene, EverydayDerivesBox285256) {
  const Scene s = parse_scene(kEveryday);
  EXPECT_NEAR(s.box.length.x, 28.5256, 5e-5);
  EXPECT_EQ(s.box.length.x, s.box.length.y);
  EXPECT_EQ(s.box.length.x, s.box.length.z);
  EXPECT_NEAR(s.reduced_density(), 0.5, 1e-12);
  EXPECT_EQ(s.shape.length, 5.0);
  EXPECT_EQ(s.n, 2304);
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{4, 24, 24}));
  EXPECT_EQ(s.axis, 0);
  EXPECT_EQ(s.dt, 1e-4);
  EXPECT_EQ(s.equilibration_steps, 100000);
  EXPECT_EQ(s.steps, 200000);
  EXPECT_EQ(s.output_dir, "runs/everyday");
}

TEST(Scene, PaperDerivesBox570512) {
  const Scene s = parse_scene(rods(18432, "reduced_density = 0.5", "lattice = [8, 48, 48]"));
  EXPECT_NEAR(s.box.length.x, 57.0512, 5e-5);
  EXPECT_NEAR(s.box.length.x / 8, 7.13, 5e-3);  // docs/physics.md section 2 spacings
  EXPECT_NEAR(s.box.length.x / 48, 1.19, 5e-3);
}

TEST(Scene, SpheresFromPackingFraction) {
  const Scene s = parse_scene(kSpheres);
  EXPECT_TRUE(s.shape.is_sphere());
  EXPECT_EQ(s.shape_name, "sphere");
  EXPECT_NEAR(s.packing_fraction(), 0.45, 1e-12);
  EXPECT_NEAR(s.box.length.x, std::cbrt(2197.0 / (0.45 / (std::numbers::pi / 6.0))), 1e-12);
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{13, 13, 13}));

  // A sphere is L/D = 0: no aspect ratio, and close packing is eta = pi / (3 sqrt 2) = 0.7405.
  std::string text = kSpheres;
  text.replace(text.find("n = 2197"), 8, "aspect_ratio = 5\nn = 2197");
  auto problems = problems_of(text);
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0], "system.aspect_ratio = 5: must be 0 (or absent) for shape = \"sphere\"");
  problems = problems_of(kSpheres, {"system.packing_fraction=0.75"});
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0],
            "system.packing_fraction = 0.75: must be in (0, 0.74048) (0.74048 = close packing)");
  // Rods pack denser: rho_cp v0 = 0.8835 at L/D = 5.
  EXPECT_NO_THROW(parse_scene(rods(2, "packing_fraction = 0.003", "lattice = [2, 1, 1]")));
  EXPECT_TRUE(contains(
      problems_of(rods(2304, "packing_fraction = 0.9", "")),
      "system.packing_fraction = 0.9: must be in (0, 0.883538) (0.883538 = close packing)"));
}

TEST(Scene, ExplicitBoxSides) {
  const Scene s = parse_scene(rods(2, "box = [13, 14.5, 15]", "lattice = [2, 1, 1]"));
  EXPECT_EQ(s.box.length.x, 13.0);
  EXPECT_EQ(s.box.length.y, 14.5);
  EXPECT_EQ(s.box.length.z, 15.0);
  const Scene cube = parse_scene(rods(1, "box = 28.5256", "lattice = [1, 1, 1]"));
  EXPECT_EQ(cube.box.length.z, 28.5256);
}

TEST(Scene, AllProblemsReportedTogether) {
  const std::string text = R"([system]
n = 2304
reduced_density = 1.2
[init]
lattice = [4, 24, 24]
axis = "w"
[run]
dt = -0.001
steps = "abc"
)";
  try {
    parse_scene(text);
    FAIL() << "parsed";
  } catch (const SceneError &error) {
    const auto &p = error.problems();
    ASSERT_EQ(p.size(), 4u) << lines(p);
    EXPECT_EQ(p[0], "system.reduced_density = 1.2: must be in (0, 1) (1 = close packing)");
    EXPECT_EQ(p[1], "init.axis = \"w\": must be \"x\", \"y\" or \"z\"");
    EXPECT_EQ(p[2], "run.dt = -0.001: must be > 0 and finite");
    EXPECT_EQ(p[3], "run.steps = \"abc\": expected an integer");
    const std::string what = error.what();
    EXPECT_EQ(std::count(what.begin(), what.end(), '\n'), 3) << what;
    EXPECT_NE(what.find("run.dt = -0.001"), std::string::npos);
  }
}

TEST(Scene, MissingRequiredKeys) {
  const auto problems = problems_of("");
  EXPECT_EQ(problems.size(), 4u) << lines(problems);
  EXPECT_TRUE(contains(problems, "missing required key 'system.n'"));
  EXPECT_TRUE(contains(problems, "one of system.reduced_density, system.packing_fraction"));
  EXPECT_TRUE(contains(problems, "missing required key 'run.dt'"));
  EXPECT_TRUE(contains(problems, "missing required key 'run.steps'"));

  const auto twice =
      problems_of(rods(2304, "reduced_density = 0.5\nbox = 30", "lattice = \"auto\""));
  ASSERT_EQ(twice.size(), 1u) << lines(twice);
  EXPECT_TRUE(
      contains(twice, "system.reduced_density = 0.5 and system.box = 30: give exactly one"));
}

TEST(Scene, UnknownKeysAndSectionsSuggest) {
  std::string text = kEveryday;
  text.replace(text.find("dt = 1e-4"), 9, "dtt = 1e-4\ndt = 1e-4");
  text += "seed = 3\n[outptu]\nlog_interval = 5\n[zzzzzzzz]\n";
  const auto problems = problems_of("n_bodies = 1\n" + text);
  EXPECT_EQ(problems.size(), 5u) << lines(problems);
  EXPECT_TRUE(contains(problems, "unknown key 'run.dtt' (did you mean 'run.dt'?)"));
  EXPECT_TRUE(contains(problems, "unknown key 'output.seed' (did you mean 'init.seed'?)"));
  EXPECT_TRUE(contains(problems, "unknown section '[outptu]' (did you mean '[output]'?)"));
  EXPECT_TRUE(contains(problems, "unknown section '[zzzzzzzz]'"));
  EXPECT_TRUE(contains(problems, "unknown key 'n_bodies'"));
}

TEST(Scene, WrongTypes) {
  const auto problems = problems_of(R"([system]
shape = 5
n = 2304.5
reduced_density = "half"
[init]
lattice = [4, "a", 24]
seed = -3
[run]
dt = "fast"
steps = 1.5
sample_interval = true
[output]
dir = ["a"]
)");
  EXPECT_EQ(problems.size(), 9u) << lines(problems);
  for (const char *expected :
       {"system.shape = 5: expected a string", "system.n = 2304.5: expected an integer",
        "system.reduced_density = \"half\": expected a number",
        "init.lattice = [4, \"a\", 24]: expected \"auto\" or an array",
        "init.seed = -3: must be >= 0", "run.dt = \"fast\": expected a number",
        "run.steps = 1.5: expected an integer", "run.sample_interval = true: expected an integer",
        "output.dir = [\"a\"]: expected a string"})
    EXPECT_TRUE(contains(problems, expected)) << expected << "\n" << lines(problems);

  // An integral float is a fine count: 1e8 steps.
  std::string text = kEveryday;
  text.replace(text.find("steps = 200000"), 14, "steps = 2e5");
  EXPECT_EQ(parse_scene(text).steps, 200000);
}

TEST(Scene, OverridesApplyBeforeValidation) {
  Scene s = parse_scene(kEveryday, {"run.dt=2e-4", "init.lattice=[24, 4, 24]", "init.axis=y",
                                    "output.dir=runs/x", "run.skin = 0.5", "init.seed=7"});
  EXPECT_EQ(s.dt, 2e-4);
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{24, 4, 24}));
  EXPECT_EQ(s.axis, 1);
  EXPECT_EQ(s.output_dir, "runs/x");
  EXPECT_EQ(s.skin, 0.5);
  EXPECT_EQ(s.seed, 7u);

  EXPECT_EQ(parse_scene(kEveryday, {"output.dir=\"runs/a b\""}).output_dir, "runs/a b");
  EXPECT_EQ(parse_scene(kEveryday, {"output.dir=2024"}).output_dir, "2024");
  EXPECT_EQ(parse_scene(kEveryday, {"output.dir=a = b"}).output_dir, "a = b");
  EXPECT_EQ(parse_scene(kEveryday, {"init.lattice=auto"}).lattice,
            (std::array<long long, 3>{4, 24, 24}));

  // A density override replaces the file's density key.
  s = parse_scene(kEveryday, {"system.packing_fraction=0.3"});
  EXPECT_NEAR(s.packing_fraction(), 0.3, 1e-12);
  s = parse_scene(kEveryday, {"system.box=[30, 31, 32]"});
  EXPECT_EQ(s.box.length.y, 31.0);

  auto problems = problems_of(kEveryday, {"run.dtt=1", "run.dt", "run.steps=abc", "foo.bar=1"});
  EXPECT_EQ(problems.size(), 4u) << lines(problems);
  EXPECT_TRUE(contains(problems,
                       "override 'run.dtt=1': unknown key 'run.dtt' (did you mean "
                       "'run.dt'?)"));
  EXPECT_TRUE(contains(problems, "override 'run.dt': expected section.key=value"));
  EXPECT_TRUE(contains(problems, "run.steps = \"abc\": expected an integer"));
  EXPECT_TRUE(contains(problems, "override 'foo.bar=1': unknown key 'foo.bar'"));

  // Overrides may add keys and sections the file does not have.
  s = parse_scene("[system]\nn = 2304\n", {"system.reduced_density=0.5", "run.dt=1e-4",
                                           "run.steps=5", "output.log_interval=10"});
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{4, 24, 24}));
  EXPECT_EQ(s.log_interval, 10);
}

TEST(Scene, LatticeProductMustEqualN) {
  const auto problems = problems_of(rods(2304, "reduced_density = 0.5", "lattice = [4, 24, 23]"));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0], "init.lattice = [4, 24, 23]: product 2208 must equal system.n = 2304");
  EXPECT_TRUE(contains(problems_of(rods(2304, "reduced_density = 0.5", "lattice = [0, 24, 24]")),
                       "init.lattice = [0, 24, 24]: counts must be >= 1"));
}

TEST(Scene, OverlappingLatticeNamesSpacing) {
  // Axis along x but the 24 rods per row put along x: 1.19 D apart where L + D = 6 is needed.
  const auto problems = problems_of(rods(2304, "reduced_density = 0.5", "lattice = [24, 4, 24]"));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_TRUE(contains(problems,
                       "init.lattice = [24, 4, 24]: bodies with their axis along x "
                       "overlap: spacing along x is 1.18857, needs >= L + D = 6"))
      << lines(problems);
  // The same lattice is fine with the axis along y.
  EXPECT_NO_THROW(parse_scene(rods(2304, "reduced_density = 0.5", "lattice = [24, 4, 24]", "y")));
  // Across: 2 x 2 x 576 along z, 0.0495 D apart.
  EXPECT_TRUE(contains(problems_of(rods(2304, "reduced_density = 0.5", "lattice = [2, 2, 576]")),
                       "spacing along z is 0.0495236, needs >= D = 1"));
}

TEST(Scene, AutoLattice) {
  Scene s = parse_scene(rods(2304, "reduced_density = 0.5", "lattice = \"auto\""));
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{4, 24, 24}));
  s = parse_scene(rods(2304, "reduced_density = 0.5", "", "z"));  // absent lattice is "auto"
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{24, 24, 4}));
  s = parse_scene(rods(18432, "reduced_density = 0.5", "lattice = \"auto\""));
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{8, 48, 48}));
  std::string spheres = kSpheres;
  spheres.replace(spheres.find("[13, 13, 13]"), 12, "\"auto\"");
  EXPECT_EQ(parse_scene(spheres).lattice, (std::array<long long, 3>{13, 13, 13}));

  // rho* = 0.9 exceeds 1 / (L + D), the densest a rectangular lattice of rods can be.
  auto problems = problems_of(rods(2304, "reduced_density = 0.9", "lattice = \"auto\""));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_TRUE(contains(problems, "init.lattice = \"auto\": no lattice nx * ny * nz = 2304 fits"));
  // 2311 is prime: only 1 x 1 x 2311 and its permutations.
  EXPECT_TRUE(contains(problems_of(rods(2311, "reduced_density = 0.5", "")), "no lattice"));
}

TEST(Scene, BoxTooSmallForInteractionRange) {
  auto problems = problems_of(rods(10, "reduced_density = 0.5", "lattice = \"auto\""));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_TRUE(contains(problems, "system.reduced_density = 0.5: cubic box side 4.6"));
  EXPECT_TRUE(contains(problems, "must exceed 2 (L + D) = 12"));
  problems = problems_of(rods(1, "box = [10, 30, 11.5]", "lattice = [1, 1, 1]"));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0],
            "system.box = [10, 30, 11.5]: side x = 10, side z = 11.5 must exceed 2 (L + D) = 12 "
            "(the minimum image must be unique)");
}

// A box the neighbour search cannot bin ([1e9, 20, 20] once ended in an unhandled
// exception) is a scene error naming the key, its value and the limit; so is the cube of a
// vanishing density. The paper's largest box passes.
TEST(Scene, BoxWithTooManyCells) {
  auto problems = problems_of(rods(768, "box = [1e9, 20, 20]", "lattice = \"auto\""));
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_TRUE(contains(problems, "system.box = [1e+09, 20, 20]: the box holds 1.2e+10 cells"))
      << lines(problems);
  EXPECT_TRUE(contains(problems, "more than the neighbour search's 2^30")) << lines(problems);
  problems = problems_of(rods(768, "reduced_density = 1e-9", "lattice = \"auto\""));
  EXPECT_TRUE(contains(problems, "system.reduced_density = 1e-09: the box holds"))
      << lines(problems);
  EXPECT_NO_THROW(parse_scene(rods(147456, "reduced_density = 0.5", "lattice = [16, 96, 96]")));
}

TEST(Scene, SyntaxErrorNamesSourceLineColumn) {
  try {
    parse_scene("[system]\nn = = 3\n", {}, "bad.toml");
    FAIL() << "parsed";
  } catch (const SceneError &error) {
    ASSERT_EQ(error.problems().size(), 1u);
    EXPECT_EQ(error.problems()[0].rfind("bad.toml:2:", 0), 0u) << error.problems()[0];
  }
}

TEST(Scene, LoadSceneMissingFileNamesPath) {
  const std::string path = "/nonexistent/hardrod/scene.toml";
  try {
    load_scene(path);
    FAIL() << "loaded";
  } catch (const SceneError &error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
  }
  EXPECT_THROW(load_scene(HARDROD_SOURCE_DIR "/scenes"), SceneError);
}

TEST(Scene, CanonicalRoundTrip) {
  std::vector<Scene> scenes = {parse_scene(kEveryday), parse_scene(kSpheres)};
  scenes.push_back(parse_scene(
      rods(6, "box = [13.1, 14.000000000000002, 0.1e2 ]", "lattice = [1, 2, 3]\nseed = 12345"),
      {"system.aspect_ratio=0.3", "run.max_overlap=0.01", "run.solver_tolerance=1e-13",
       "run.skin=2", "run.solver_max_iterations=7", "output.log_interval=3", "init.temperature=0.7",
       "run.thermostat_interval=0", R"(output.dir="runs/\u00e4 \"q\" \\ tab	del" )"}));
  scenes.push_back(parse_scene(
      kEveryday, {"system.reduced_density=0.123456789", "init.axis=z", "init.lattice=auto"}));
  for (const Scene &s : scenes) {
    const std::string text = scene_to_toml(s);
    const Scene back = parse_scene(text);
    EXPECT_TRUE(same(s, back)) << text;
    EXPECT_EQ(scene_to_toml(back), text);
  }
  EXPECT_EQ(scenes[2].output_dir, "runs/\xc3\xa4 \"q\" \\ tab\tdel");
}

TEST(Scene, ShippedScenesParse) {
  int count = 0;
  for (const auto &entry : std::filesystem::directory_iterator(HARDROD_SOURCE_DIR "/scenes")) {
    if (entry.path().extension() != ".toml") continue;
    ++count;
    try {
      const Scene s = load_scene(entry.path().string());
      expect_invariants(s, entry.path().string());
    } catch (const SceneError &error) {
      ADD_FAILURE() << entry.path() << ":\n" << error.what();
    }
  }
  EXPECT_GE(count, 3);
  EXPECT_NEAR(load_scene(HARDROD_SOURCE_DIR "/scenes/everyday.toml").box.length.x, 28.5256, 5e-5);
  EXPECT_NEAR(load_scene(HARDROD_SOURCE_DIR "/scenes/paper.toml").box.length.x, 57.0512, 5e-5);
  EXPECT_NEAR(load_scene(HARDROD_SOURCE_DIR "/scenes/hard-spheres.toml").packing_fraction(), 0.45,
              1e-12);
}

// Values a fuzzed scene puts where a value was: every TOML type, the edges of the numbers,
// and values of other keys.
// clang-format off
const std::vector<std::string> kJunkValues = {
    "", "-1", "0", "1e308", "-0.0", "nan", "inf", "-inf", "\"abc\"", "[1, 2]", "[]", "{}",
    "{a = 1}", "true", "9223372036854775807", "-9223372036854775808", "1979-05-27", "'lit'",
    "[[1], [2]]", "\"auto\"", "0x10", "1_000", "[4, 24, 24]", "2304", "0.5", "\"sphere\"",
    "[1e300, 1, 1]", "4.9e-324", "\"\\u0000\"", "[13, 13, 13]", "1e-300", "\"z\""};
// clang-format on

// One random damage to `text` at a random place: a character deleted, a line duplicated, a
// value replaced with junk, or a byte flipped.
void damage(std::string &text, const std::function<std::size_t(std::size_t)> &pick) {
  const std::size_t at = pick(text.size());
  switch (pick(4)) {
    case 0:
      text.erase(at, 1);
      break;
    case 1: {
      const std::size_t begin =
          text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
      const std::size_t end = text.find('\n', at);
      const std::string line =
          text.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1);
      text.insert(begin, line);
      break;
    }
    case 2: {
      const std::size_t equals = text.find(" = ", at);
      if (equals == std::string::npos) break;
      const std::size_t end = text.find('\n', equals);
      text.replace(equals + 3, end == std::string::npos ? std::string::npos : end - equals - 3,
                   kJunkValues[pick(kJunkValues.size())]);
      break;
    }
    default:
      text[at] = static_cast<char>(text[at] ^ (1 << pick(8)));
      break;
  }
}

// Random damage to a valid scene: parse_scene must accept it (and then the scene keeps every
// invariant and round-trips) or throw SceneError with non-empty problems; nothing else.
TEST(Scene, FuzzedScenesParseOrFailCleanly) {
  std::mt19937_64 random(20240601);
  auto pick = [&](std::size_t size) {
    return std::uniform_int_distribution<std::size_t>(0, size - 1)(random);
  };
  int accepted = 0;
  constexpr int kTrials = 4000;
  for (int trial = 0; trial < kTrials; ++trial) {
    std::string text = kEveryday;
    const int mutations = 1 + static_cast<int>(pick(3));
    for (int m = 0; m < mutations && !text.empty(); ++m) damage(text, pick);
    try {
      const Scene s = parse_scene(text, {}, "fuzz.toml");
      ++accepted;
      expect_invariants(s, text);
      EXPECT_TRUE(same(parse_scene(scene_to_toml(s)), s)) << text;
    } catch (const SceneError &error) {
      EXPECT_FALSE(error.problems().empty()) << text;
      for (const auto &problem : error.problems()) EXPECT_FALSE(problem.empty()) << text;
    } catch (const std::exception &error) {
      ADD_FAILURE() << "unexpected exception: " << error.what() << "\n" << text;
    } catch (...) {
      ADD_FAILURE() << "unexpected non-standard exception\n" << text;
    }
    if (HasFailure()) break;
  }
  // Both outcomes must be exercised for the test to mean anything.
  EXPECT_GT(accepted, kTrials / 50);
  EXPECT_LT(accepted, kTrials - kTrials / 50);
}

}  // namespace
}  // namespace hardrod
