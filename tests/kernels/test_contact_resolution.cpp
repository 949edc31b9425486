// Elastic impulses: an isolated pair conserves momentum, angular momentum and kinetic
// energy to round-off for any geometry; a multi-contact cluster conserves momentum and
// angular momentum, meets its targets, and gives the same bits for any thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <random>

#include "kernels/contact_detection.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/thermostat.hpp"

namespace hardrod {
namespace {

struct Invariants {
  Vec3 momentum, angular_momentum;
  double energy = 0.0;
};

// Positions are taken as stored (the tests keep bodies away from the box edges so no
// minimum image is needed for the angular momentum).
Invariants invariants(const Particles &p, const Shape &shape) {
  Invariants inv;
  const double inertia = shape.is_sphere() ? 0.0 : shape.inertia_perp();
  for (std::size_t i = 0; i < p.size(); ++i) {
    inv.momentum += shape.mass * p.velocity(i);
    inv.angular_momentum +=
        shape.mass * cross(p.position(i), p.velocity(i)) + inertia * p.angular_velocity(i);
    inv.energy +=
        0.5 * shape.mass * norm2(p.velocity(i)) + 0.5 * inertia * norm2(p.angular_velocity(i));
  }
  return inv;
}

Vec3 random_unit(std::mt19937_64 &rng) {
  std::normal_distribution<double> g;
  Vec3 v{g(rng), g(rng), g(rng)};
  return (1.0 / norm(v)) * v;
}

void randomise_motion(Particles &p, std::mt19937_64 &rng, double speed) {
  std::normal_distribution<double> g;
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.set_velocity(i, speed * Vec3{g(rng), g(rng), g(rng)});
    Vec3 w = speed * Vec3{g(rng), g(rng), g(rng)};
    w -= dot(w, p.axis(i)) * p.axis(i);
    p.set_angular_velocity(i, w);
  }
}

TEST(ContactResolution, IsolatedPairConservesEverything) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Box box;
  box.length = {100, 100, 100};
  int approaching = 0;
  for (double length : {0.0, 1.0, 5.0, 50.0}) {
    Shape shape;
    shape.length = length;
    for (int trial = 0; trial < 500; ++trial) {
      Particles p;
      p.resize(2);
      p.id = {0, 1};
      p.set_position(0, {50, 50, 50});
      p.set_axis(0, random_unit(rng));
      p.set_axis(1, random_unit(rng));
      // Place j so that the axes are a little closer than D.
      const double reach = 0.5 * length;
      Vec3 offset{u(rng) * (reach + 1), u(rng) * (reach + 1), u(rng) * (reach + 1)};
      p.set_position(1, p.position(0) + offset);
      Contact c;
      double d = 0;
      if (!make_contact(p, box, box.inverse_length(), shape, 0, 1, c, d)) continue;
      randomise_motion(p, rng, 1.0);
      const Invariants before = invariants(p, shape);
      std::vector<Contact> contacts{c};
      resolve_contacts(p, shape, contacts, SolverSettings{});
      const auto tally = tally_collisions(contacts, {});
      const Invariants after = invariants(p, shape);
      const double scale = 1.0 + before.energy;
      EXPECT_NEAR(after.momentum.x, before.momentum.x, 1e-13 * scale);
      EXPECT_NEAR(after.momentum.y, before.momentum.y, 1e-13 * scale);
      EXPECT_NEAR(after.momentum.z, before.momentum.z, 1e-13 * scale);
      const double lscale = 1e-13 * scale * 100;  // positions are ~50
      EXPECT_NEAR(after.angular_momentum.x, before.angular_momentum.x, lscale);
      EXPECT_NEAR(after.angular_momentum.y, before.angular_momentum.y, lscale);
      EXPECT_NEAR(after.angular_momentum.z, before.angular_momentum.z, lscale);
      EXPECT_NEAR(after.energy, before.energy, 1e-13 * scale);
      if (contacts[0].approach_velocity < 0) {
        ++approaching;
        EXPECT_EQ(tally.collisions, 1);
        // Elastic: the normal velocity is reversed exactly.
        EXPECT_NEAR(normal_velocity(p, contacts[0]), -contacts[0].approach_velocity, 1e-12);
      } else {
        EXPECT_EQ(tally.collisions, 0);  // receding contacts are left alone
      }
    }
  }
  EXPECT_GT(approaching, 200);
}

// A dense random cluster: many bodies with several contacts each.
struct Cluster {
  Particles p;
  Box box;
  Shape shape;
  std::vector<Contact> contacts;
};

Cluster dense_cluster(double length, std::uint64_t seed) {
  Cluster c;
  c.shape.length = length;
  c.box.length = {60, 60, 60};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::size_t n = 60;
  c.p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.p.id[i] = static_cast<std::int64_t>(i);
    const double side = length > 0 ? 5.0 : 3.0;
    c.p.set_position(i, {28 + side * u(rng), 28 + side * u(rng), 28 + side * u(rng)});
    c.p.set_axis(i, random_unit(rng));
  }
  randomise_motion(c.p, rng, 1.0);
  NeighborList list;
  build_neighbor_list(list, c.p, n, c.box, c.shape);
  detect_contacts(c.p, c.box, c.shape, list, c.contacts);
  return c;
}

TEST(ContactResolution, MultiContactClusterConservesMomentumAndMeetsTargets) {
  for (double length : {0.0, 5.0}) {
    Cluster c = dense_cluster(length, 11);
    ASSERT_GT(c.contacts.size(), 20u);
    const Invariants before = invariants(c.p, c.shape);
    SolverSettings settings;
    settings.tolerance = 1e-12;
    settings.max_iterations = 100000;
    const auto stats = resolve_contacts(c.p, c.shape, c.contacts, settings);
    EXPECT_GT(stats.clusters, 0);
    EXPECT_GT(find_clusters(c.contacts).multi_contact_bodies, 0);
    EXPECT_EQ(stats.unconverged, 0);
    const Invariants after = invariants(c.p, c.shape);
    EXPECT_NEAR(after.momentum.x, before.momentum.x, 1e-11);
    EXPECT_NEAR(after.momentum.y, before.momentum.y, 1e-11);
    EXPECT_NEAR(after.momentum.z, before.momentum.z, 1e-11);
    EXPECT_NEAR(after.angular_momentum.x, before.angular_momentum.x, 1e-9);
    EXPECT_NEAR(after.angular_momentum.y, before.angular_momentum.y, 1e-9);
    EXPECT_NEAR(after.angular_momentum.z, before.angular_momentum.z, 1e-9);
    // Complementarity: every contact separates at least as fast as its target, and
    // contacts that received an impulse meet the target.
    for (const Contact &k : c.contacts) {
      const double target = k.approach_velocity < 0 ? -k.approach_velocity : 0.0;
      const double u = normal_velocity(c.p, k);
      EXPECT_GE(u, target - 1e-9);
      EXPECT_GE(k.impulse, 0.0);
      if (k.impulse > 0) {
        EXPECT_NEAR(u, target, 1e-9);
      }
    }
  }
}

TEST(ContactResolution, SameBitsForAnyThreadCount) {
  Cluster ref = dense_cluster(5.0, 3);
  omp_set_num_threads(1);
  resolve_contacts(ref.p, ref.shape, ref.contacts, SolverSettings{});
  const auto s1 = tally_collisions(ref.contacts, {});
  for (int threads : {2, 4}) {
    Cluster c = dense_cluster(5.0, 3);
    omp_set_num_threads(threads);
    resolve_contacts(c.p, c.shape, c.contacts, SolverSettings{});
    const auto s = tally_collisions(c.contacts, {});
    EXPECT_EQ(s.virial.raw(), s1.virial.raw());
    EXPECT_EQ(c.p.vx, ref.p.vx);
    EXPECT_EQ(c.p.wy, ref.p.wy);
  }
  omp_set_num_threads(1);
}

}  // namespace
}  // namespace hardrod
