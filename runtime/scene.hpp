// A scene: everything a run needs, read from a TOML file plus command-line overrides.
// The key names are the public interface: [system], [init], [run], [output].
// Every problem in a scene is collected and reported together, each naming key and value.
#pragma once

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// All problems found in a scene, one line each ("run.dt = -1: must be > 0").
class SceneError : public std::runtime_error {
 public:
  explicit SceneError(std::vector<std::string> problems);
  const std::vector<std::string> &problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

// Where the bodies start: the aligned lattice, a random isotropic state compressed to the
// density (kernels/isotropic_start.hpp), or positions and axes read from an H5MD file.
enum class Configuration { kLattice, kFile, kIsotropic };

// How a step times its collisions (run.method, docs/physics.md section 3): at the step's
// midpoint once bodies overlap, the paper's method; or at their exact times within the step
// (kernels/exact/exact_collisions.hpp).
enum Method : int { kMidpoint = 0, kExact = 1 };

struct Scene {
  // [system]
  std::string shape_name = "spherocylinder";  // "spherocylinder" or "sphere"
  Shape shape;                                // aspect_ratio -> shape.length (D = 1)
  long long n = 0;
  Box box;  // from reduced_density, packing_fraction or box
  // [init]
  Configuration configuration = Configuration::kLattice;
  std::array<long long, 3> lattice{0, 0, 0};  // bodies per axis; "auto" resolved here
  std::string init_file;                      // configuration = "file": an H5MD file
  long long init_frame = -1;                  // its frame; < 0 counts from the end
  long long isotropic_sweeps = 200000;        // configuration = "isotropic": MC sweeps allowed
  int axis = 0;                               // 0 = x, 1 = y, 2 = z
  unsigned long long seed = 1;
  double temperature = 1.0;  // kT
  // [run]
  double dt = 1e-4;
  int method = kMidpoint;  // run.method: how collisions are timed (Method)
  long long equilibration_steps = 0;
  long long steps = 0;
  long long thermostat_interval = 200;  // 0 = off
  long long sample_interval = 1000;
  double max_overlap = 0.05;        // in D; deeper overlap stops the run
  double solver_tolerance = 1e-10;  // relative, multi-contact solver
  long long solver_max_iterations = 1000;
  double skin = 0.3;  // neighbour-list skin in D (speed only)
  // [output]
  std::string output_dir = "runs/default";
  long long log_interval = 0;         // steps between plain progress lines; 0 = auto
  long long snapshot_interval = 0;    // steps between H5MD frames; 0 = the final state only
  long long checkpoint_interval = 0;  // steps between checkpoints; 0 = at the end (and on a signal)
  // [observables]
  bool frank = false;              // accumulate the Fourier order tensor (Frank constants)
  int fourier_kmax = 10;           // modes -kmax < k_a < kmax, k != 0; unset: from the box
  long long fourier_interval = 0;  // steps between Fourier samples; 0 = sample_interval

  double number_density() const { return static_cast<double>(n) / box.volume(); }
  double reduced_density() const { return number_density() / shape.close_packing_density(); }
  double packing_fraction() const { return number_density() * shape.volume(); }
};

// Parse a TOML file, apply "section.key=value" overrides (value in TOML syntax, strings may
// be bare), validate, and derive the box. Throws SceneError listing every problem.
Scene load_scene(const std::string &path, const std::vector<std::string> &overrides = {});
Scene parse_scene(const std::string &toml_text, const std::vector<std::string> &overrides = {},
                  const std::string &source_name = "<string>");

// The scene as canonical TOML (written next to a run's output so it can be reproduced).
std::string scene_to_toml(const Scene &scene);

// Every scene key, one line each in canonical order: "run.dt (number; required): time step
// in tau". From the key table (runtime/scene_keys.hpp), so it cannot fall behind the reader.
std::string scene_keys_reference();

}  // namespace hardrod
