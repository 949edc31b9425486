// The scene-key table (runtime/scene_keys.hpp): it is the one spelling of the keys, so every
// key has help and a line in the reference, is found by name, is written back exactly when it
// applies, and is reported by name and value when given a wrong value; the defaults of the
// keys a scene may leave out are pinned here. The reading itself: test_scene.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "runtime/scene.hpp"
#include "runtime/scene_keys.hpp"
#include "tests/scene_problems.hpp"

namespace hardrod {
namespace {

using namespace scene_detail;

// Every key given: the file keys are set by the tests that need them.
const std::string kScene = R"([system]
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
equilibration_steps = 10
steps = 20
thermostat_interval = 200
sample_interval = 1000
max_overlap = 0.05
solver_tolerance = 1e-10
solver_max_iterations = 1000
skin = 0.3
[output]
dir = "runs/keys"
log_interval = 0
snapshot_interval = 0
checkpoint_interval = 0
[observables]
frank = false
fourier_kmax = 6
fourier_interval = 0
)";

using testing::contains;
using testing::lines;
using testing::problems_of;

// The key table is the one spelling of the keys: every key has help, is known to --set, and
// the canonical writer writes exactly the table's keys that apply (densities as the box).
TEST(SceneKeys, KeyTableDrivesReferenceOverridesAndWriter) {
  const std::string reference = scene_keys_reference();
  const auto keys = scene_keys();
  EXPECT_EQ(keys.size(), 31u);
  EXPECT_EQ(std::count(reference.begin(), reference.end(), '\n'), 31) << reference;
  for (const auto &spec : keys) {
    const std::string key = std::string(spec.section) + "." + std::string(spec.name);
    EXPECT_FALSE(spec.help.empty()) << key;
    EXPECT_NE(reference.find(key + " ("), std::string::npos) << key << "\n" << reference;
    EXPECT_EQ(find_key(key), &spec) << key;
  }
  EXPECT_NE(reference.find("run.dt (number; required): time step in tau"), std::string::npos)
      << reference;
  EXPECT_NE(reference.find("run.thermostat_interval (integer; 200): "), std::string::npos)
      << reference;
  EXPECT_NE(reference.find("init.lattice (\"auto\" or [3 integers]; \"auto\"): "),
            std::string::npos)
      << reference;

  // Written: every key but the densities (the box stands for them), the lattice only for a
  // lattice start, the file keys only for a file start and the sweeps only for an isotropic one.
  for (const char *configuration : {"lattice", "file", "isotropic"}) {
    std::vector<std::string> set = {std::string("init.configuration=") + configuration};
    if (std::string(configuration) == "file") set.push_back("init.file=x.h5");
    const std::string text = scene_to_toml(parse_scene(kScene, set));
    for (const auto &spec : keys) {
      std::string line = "\n";
      line += spec.name;
      line += " = ";
      const bool density = spec.name == "reduced_density" || spec.name == "packing_fraction";
      const std::string start = configuration;
      const bool applies = spec.name == "lattice"                        ? start == "lattice"
                           : spec.name == "file" || spec.name == "frame" ? start == "file"
                           : spec.name == "isotropic_sweeps"             ? start == "isotropic"
                                                                         : true;
      EXPECT_EQ(text.find(line) != std::string::npos, !density && applies)
          << spec.name << " with configuration " << configuration << ":\n"
          << text;
    }
  }
}

// The defaults of the keys a scene may leave out (the public defaults).
TEST(SceneKeys, DefaultsOfAbsentKeys) {
  const Scene s = parse_scene(
      "[system]\nn = 2304\nreduced_density = 0.5\n[run]\ndt = 1e-4\n"
      "steps = 10\n");
  EXPECT_EQ(s.shape_name, "spherocylinder");
  EXPECT_EQ(s.shape.length, 5.0);
  EXPECT_EQ(s.configuration, Configuration::kLattice);
  EXPECT_EQ(s.lattice, (std::array<long long, 3>{4, 24, 24}));  // "auto"
  EXPECT_EQ(s.axis, 0);
  EXPECT_EQ(s.seed, 1u);
  EXPECT_EQ(s.temperature, 1.0);
  EXPECT_EQ(s.equilibration_steps, 0);
  EXPECT_EQ(s.thermostat_interval, 200);
  EXPECT_EQ(s.sample_interval, 1000);
  EXPECT_EQ(s.max_overlap, 0.05);
  EXPECT_EQ(s.solver_tolerance, 1e-10);
  EXPECT_EQ(s.solver_max_iterations, 1000);
  EXPECT_EQ(s.skin, 0.3);
  EXPECT_EQ(s.output_dir, "runs/default");
  EXPECT_EQ(s.log_interval, 0);
  EXPECT_EQ(s.snapshot_interval, 0);
  EXPECT_EQ(s.checkpoint_interval, 0);
  EXPECT_FALSE(s.frank);
  EXPECT_EQ(s.fourier_kmax, 6);  // from the 28.5 D box
  EXPECT_EQ(s.fourier_interval, 0);
  EXPECT_EQ(parse_scene("[system]\nshape = \"sphere\"\nn = 8\npacking_fraction = 0.1\n[run]\n"
                        "dt = 1e-4\nsteps = 1\n")
                .shape.length,
            0.0);  // a sphere's aspect ratio
}

// Every key, given a value of the wrong kind by --set, is reported with its name and value.
TEST(SceneKeys, EveryKeyRejectsAWrongValueByName) {
  for (const auto &spec : scene_keys()) {
    const std::string key = std::string(spec.section) + "." + std::string(spec.name);
    // The file keys are read only for a file start, the lattice only for a lattice start, the
    // sweeps only for an isotropic one.
    std::vector<std::string> set = {"init.configuration=file", "init.file=x.h5"};
    if (spec.name == "lattice") set.clear();
    if (spec.name == "isotropic_sweeps") set = {"init.configuration=isotropic"};
    // A string key takes any text, so give it an empty one (the shape and the choices: a name
    // that is none of theirs); every other key gets a table.
    const bool string_key = is_string_key(spec);
    const std::string value = string_key ? "\"\"" : "{a = 1}";
    set.push_back(key + "=" + value);
    const auto problems = problems_of(kScene, set);
    EXPECT_TRUE(contains(problems, key + " = " + (string_key ? "\"\"" : "{...}") + ": "))
        << key << "\n"
        << lines(problems);
  }
}

// Step counts and intervals are bounded so that no step arithmetic can overflow: 2^63 - 1 is
// refused by name with the largest accepted value, and so is a sum past it.
TEST(SceneKeys, StepCountsAndIntervalsHaveALargestValue) {
  const std::string huge = "9223372036854775807";
  for (const char *key : {"run.steps", "run.equilibration_steps", "run.thermostat_interval",
                          "run.sample_interval", "output.log_interval", "output.snapshot_interval",
                          "output.checkpoint_interval", "observables.fourier_interval"}) {
    const auto problems = problems_of(kScene, {std::string(key) + "=" + huge});
    EXPECT_TRUE(
        contains(problems, std::string(key) + " = " + huge + ": must be at most 1000000000000000"))
        << key << "\n"
        << lines(problems);
  }
  const auto sum = problems_of(kScene, {"run.equilibration_steps=1000000000000000", "run.steps=1"});
  EXPECT_TRUE(contains(sum, "run.steps = 1: run.equilibration_steps + run.steps must be at most"))
      << lines(sum);
  EXPECT_EQ(parse_scene(kScene, {"run.equilibration_steps=999999999999999", "run.steps=1"}).steps,
            1);
}

// Hard bodies: the temperature only sets the time scale, so an absurd one is a mistake in the
// scene, said so by name, not a physics break later blamed on dt.
TEST(SceneKeys, TemperatureHasLimits) {
  for (const char *value : {"1e-30", "1e300", "0", "-1"}) {
    const auto problems = problems_of(kScene, {std::string("init.temperature=") + value});
    ASSERT_EQ(problems.size(), 1u) << lines(problems);
    EXPECT_EQ(problems[0].rfind("init.temperature = ", 0), 0u) << lines(problems);
    EXPECT_TRUE(contains(problems, ": must be in (1e-06, 1e+06)")) << lines(problems);
  }
}

// The Frank fit needs two modes per axis at least: kmax = 1 is a scene error naming the key, not
// an internal error when the first sample is accumulated.
TEST(SceneKeys, FourierKmaxIsAtLeastTwo) {
  const auto problems =
      problems_of(kScene, {"observables.frank=true", "observables.fourier_kmax=1"});
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0].rfind("observables.fourier_kmax = 1", 0), 0u) << lines(problems);
  EXPECT_TRUE(contains(problems, ">= 2")) << lines(problems);
  EXPECT_EQ(parse_scene(kScene, {"observables.fourier_kmax=2"}).fourier_kmax, 2);
}

// run.method names how collisions are timed; anything else is refused with the choices.
TEST(SceneKeys, MethodIsMidpointOrExact) {
  EXPECT_EQ(parse_scene(kScene).method, kMidpoint);
  EXPECT_EQ(parse_scene(kScene, {"run.method=exact"}).method, kExact);
  EXPECT_NE(scene_to_toml(parse_scene(kScene, {"run.method=exact"})).find("method = \"exact\""),
            std::string::npos);
  // The skin's default follows the method; a skin given stays.
  std::string no_skin = kScene;
  no_skin.erase(no_skin.find("skin = 0.3\n"), 11);
  EXPECT_EQ(parse_scene(no_skin).skin, 0.3);
  EXPECT_EQ(parse_scene(no_skin, {"run.method=exact"}).skin, 1.0);  // rods
  EXPECT_EQ(parse_scene("[system]\nshape = \"sphere\"\nn = 8\npacking_fraction = 0.1\n[run]\n"
                        "dt = 1e-3\nsteps = 10\nmethod = \"exact\"\n")
                .skin,
            0.6);
  EXPECT_EQ(parse_scene(kScene, {"run.method=exact"}).skin, 0.3);
  EXPECT_EQ(parse_scene(no_skin, {"run.method=exact", "run.skin=0.4"}).skin, 0.4);
  const auto problems = problems_of(kScene, {"run.method=leapfrog"});
  ASSERT_EQ(problems.size(), 1u) << lines(problems);
  EXPECT_EQ(problems[0], "run.method = \"leapfrog\": must be \"midpoint\" or \"exact\"")
      << lines(problems);
}

}  // namespace
}  // namespace hardrod
