// Rigid-body properties of a hard spherocylinder (capsule) of diameter D = 1, mass 1.
// Physics: docs/physics.md section 1. A capsule is a linear rotor: frictionless contact forces act
// through the axis, so only the perpendicular moment of inertia enters. L = 0 is a sphere,
// which has no rotational degrees of freedom (inverse inertia 0, same code path).
#pragma once

#include <numbers>

namespace hardrod {

struct Shape {
  double length = 5.0;    // cylinder length L (axis segment length), in units of D
  double diameter = 1.0;  // D
  double mass = 1.0;

  bool is_sphere() const { return length == 0.0; }
  double half_length() const { return 0.5 * length; }
  double radius() const { return 0.5 * diameter; }

  // Volume of one body, v0 = pi D^2 (D/6 + L/4).
  double volume() const {
    return std::numbers::pi * diameter * diameter * (diameter / 6.0 + length / 4.0);
  }

  // I_perp of a uniform capsule (cylinder plus two hemispherical caps), docs/physics.md section 1.
  double inertia_perp() const {
    const double r = radius();
    const double vc = std::numbers::pi * r * r * length;
    const double vs = 4.0 / 3.0 * std::numbers::pi * r * r * r;
    const double mc = mass * vc / (vc + vs);
    const double ms = mass * vs / (vc + vs);
    return mc * (length * length / 12.0 + r * r / 4.0) +
           ms * (2.0 * r * r / 5.0 + length * length / 4.0 + 3.0 * length * r / 8.0);
  }
  // Spheres do not rotate: their inverse inertia is zero, so contacts never spin them.
  double inverse_inertia() const { return is_sphere() ? 0.0 : 1.0 / inertia_perp(); }
  // Translational plus rotational degrees of freedom per body (3 + 2 for a linear rotor).
  int degrees_of_freedom() const { return is_sphere() ? 3 : 5; }

  // Close packing density of aligned spherocylinders, rho_cp = 2 / (sqrt 2 + (L/D) sqrt 3).
  double close_packing_density() const {
    return 2.0 / (std::numbers::sqrt2 + (length / diameter) * std::numbers::sqrt3) /
           (diameter * diameter * diameter);
  }
  // Largest centre-centre distance at which two bodies can touch.
  double interaction_range() const { return length + diameter; }
};

}  // namespace hardrod
