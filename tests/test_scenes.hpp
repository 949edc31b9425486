// Small scenes built in code for the tests (no file parsing involved).
#pragma once

#include <cmath>
#include <string>

#include "runtime/exact/exact_step.hpp"
#include "runtime/scene.hpp"
#include "runtime/start.hpp"
#include "runtime/system.hpp"

namespace hardrod::testing {

// L/D = 5 rods at rho* = 0.5 on an aligned lattice: the everyday scene halved again
// (2 x 12 x 12 = 288 rods, box 14.2628).
inline Scene small_nematic(double dt = 1e-4) {
  Scene s;
  s.shape_name = "spherocylinder";
  s.shape.length = 5.0;
  s.lattice = {2, 12, 12};
  s.n = 288;
  const double side = std::cbrt(static_cast<double>(s.n) / (0.5 * s.shape.close_packing_density()));
  s.box.length = {side, side, side};
  s.axis = 0;
  s.seed = 5;
  s.dt = dt;
  s.equilibration_steps = 0;
  s.steps = 1000;
  s.thermostat_interval = 0;
  s.sample_interval = 100;
  return s;
}

// Hard spheres at packing fraction eta on an n^3 simple cubic lattice.
inline Scene hard_spheres(int per_side, double eta, double dt = 1e-4) {
  Scene s;
  s.shape_name = "sphere";
  s.shape.length = 0.0;
  s.lattice = {per_side, per_side, per_side};
  s.n = static_cast<long long>(per_side) * per_side * per_side;
  const double side = std::cbrt(static_cast<double>(s.n) * s.shape.volume() / eta);
  s.box.length = {side, side, side};
  s.seed = 3;
  s.dt = dt;
  s.steps = 1000;
  s.thermostat_interval = 0;
  s.sample_interval = 100;
  return s;
}

// The exact method's record of a System that runs it.
inline const ExactRecord &exact_record(const System &sys) {
  return dynamic_cast<const ExactStep &>(sys.method()).record();
}
inline const ListExtension &list_extension(const System &sys) {
  return dynamic_cast<const ExactStep &>(sys.method()).extension();
}

// What a start from `scene` fails with (initial_bodies' SceneError), "" if it starts.
inline std::string start_error(const Scene &scene) {
  try {
    initial_bodies(scene);
  } catch (const SceneError &e) {
    return e.what();
  }
  return "";
}

}  // namespace hardrod::testing
