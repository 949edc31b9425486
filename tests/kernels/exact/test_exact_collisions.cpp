// The exact method's collisions within one step (kernels/exact/exact_collisions.hpp), on bodies set
// up by hand: the contact time and the impulse of a head-on pair against the closed form, the
// virial at contact, a chain whose velocity changes reach bodies outside the first clusters,
// the event cap's fallback, the pieces several ranks use (collide_once, overrun_reaches)
// against the one-rank loop, and the one queue against the clusters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <tuple>
#include <utility>

#include "kernels/contact_detection.hpp"
#include "kernels/exact/exact_collisions.hpp"
#include "kernels/exact/exact_events.hpp"
#include "kernels/free_flight.hpp"
#include "kernels/neighbor_list.hpp"
#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

// One exact step of bodies p (list built here): what runtime/exact/exact_step.cpp does on one rank.
struct Step {
  ExactStats stats;
  std::vector<FlownBody> flown;
};
Step exact_step(Particles &p, const Box &box, const Shape &shape, double dt,
                ExactSettings settings = {}) {
  NeighborList list;
  list.skin = 1.0;
  build_neighbor_list(list, p, p.size(), box, shape);
  refresh_motion(p, p.size(), shape, 0.5 * dt);
  grow_bounds(p, p.size());
  std::vector<Candidate> candidates;
  const StepAhead ahead{p.grow.data(), dt};
  detect_candidates(p, box, shape, list, candidates, ahead);
  ExactScratch scratch;
  Step s;
  s.stats = collide_exactly(p, box, shape, list, candidates, dt, settings, scratch, s.flown);
  fly_step(p, p.size(), shape, 0.5 * dt);
  land_flown(p, s.flown, !shape.is_sphere());
  return s;
}

Particles spheres_on_x(const std::vector<double> &x, const std::vector<double> &vx) {
  Particles p;
  p.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i, {x[i], 5.0, 5.0});
    p.set_axis(i, {1.0, 0.0, 0.0});
    p.set_velocity(i, {vx[i], 0.0, 0.0});
  }
  return p;
}

TEST(ExactCollisions, HeadOnSpheresMeetAtTheClosedFormTime) {
  const Shape sphere{.length = 0.0};
  const Box box{{20.0, 20.0, 20.0}};
  const double dt = 0.01;
  // 1.004 D apart, closing at 2: they touch at t* = 0.002, then swap velocities.
  Particles p = spheres_on_x({5.0, 6.004}, {1.0, -1.0});
  const Step s = exact_step(p, box, sphere, dt);
  EXPECT_EQ(s.stats.collisions, 1);
  EXPECT_EQ(s.stats.candidates, 1);
  ASSERT_EQ(s.flown.size(), 2u);
  EXPECT_DOUBLE_EQ(p.vx[0], -1.0);
  EXPECT_DOUBLE_EQ(p.vx[1], 1.0);
  // Flown to t* and back out for dt - t*.
  const double t_star = 0.004 / 2.0;
  EXPECT_NEAR(p.x[0], 5.0 + t_star - (dt - t_star), 1e-10);
  EXPECT_NEAR(p.x[1], 6.004 - t_star + (dt - t_star), 1e-10);
  // J = m |u| = 2, n . (x_0 - x_1) = -D at contact (n from 1 to 0 points along -x): J n.r = 2 D.
  EXPECT_NEAR(s.stats.virial.value(), 2.0, 1e-9);
}

// A sphere's axis and spin play no part in its collisions, and the exact method leaves them as
// they were (its flights do not carry them, start_flight; its landing does not write them,
// land_flown): tilted axes and spins give the same positions and velocities, to the bit, as
// none, in the one queue and by clusters, and stay as they were set.
TEST(ExactCollisions, ASpheresAxisAndSpinPlayNoPartAndStayAsTheyWere) {
  const Shape sphere{.length = 0.0};
  const Box box{{20.0, 20.0, 20.0}};
  const double dt = 0.02;
  // Two pairs meeting off-centre.
  Particles plain = spheres_on_x({5.0, 6.0, 10.0, 11.0}, {1.0, -1.0, 0.5, -0.7});
  for (std::size_t i = 0; i < plain.size(); ++i) plain.y[i] += 0.2 * static_cast<double>(i % 2);
  Particles turned = plain;
  for (std::size_t i = 0; i < turned.size(); ++i) {
    const double a = 0.3 + 0.7 * static_cast<double>(i);
    const Vec3 e{std::cos(a), std::sin(a), 0.25};
    turned.set_axis(i, (1.0 / norm(e)) * e);
    turned.set_angular_velocity(i, {0.4 - 0.3 * static_cast<double>(i), 1.5, -2.0});
  }
  for (const bool one_queue : {false, true}) {
    ExactSettings settings;
    settings.one_queue = one_queue;
    Particles a = plain, b = turned;
    const Step sa = exact_step(a, box, sphere, dt, settings);
    const Step sb = exact_step(b, box, sphere, dt, settings);
    ASSERT_EQ(sa.stats.collisions, 2) << one_queue;
    EXPECT_EQ(sb.stats.collisions, 2) << one_queue;
    EXPECT_NE(a.vx[0], 1.0);  // the collisions changed the velocities
    const auto same = [](const std::vector<double> &x, const std::vector<double> &y) {
      return x.size() == y.size() &&
             std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
    };
    for (BodyField field : {&Particles::x, &Particles::y, &Particles::z, &Particles::vx,
                            &Particles::vy, &Particles::vz})
      EXPECT_TRUE(same(a.*field, b.*field)) << "one_queue " << one_queue;
    for (BodyField field : {&Particles::ex, &Particles::ey, &Particles::ez, &Particles::wx,
                            &Particles::wy, &Particles::wz})
      EXPECT_TRUE(same(b.*field, turned.*field)) << "one_queue " << one_queue;
  }
}

// An oblique touch of two spheres (give_impulse, its sphere path): the velocity components
// along the line of centres are exchanged, the others kept, and the virial is J n . (x_a - x_b)
// with J the momentum exchanged.
TEST(ExactEvents, AnObliqueSphereImpulseExchangesTheNormalComponents) {
  const Shape sphere{.length = 0.0};
  const Vec3 n = (1.0 / std::sqrt(1.0 + 0.36 + 0.09)) * Vec3{1.0, 0.6, -0.3};  // from a to b
  Flight a{{1.0, 2.0, 3.0}, {0.0, 0.0, 1.0}, {0.7, -0.2, 0.4}, {}, 0.0};
  Flight b = a;
  b.x = a.x + sphere.diameter * n;
  b.v = {-0.5, 0.3, 0.1};
  const Vec3 va = a.v, vb = b.v;
  const exact_events::Touch touch = exact_events::give_impulse(a, b, b.x, sphere);
  ASSERT_TRUE(touch.closing);
  const double ua = dot(va, n), ub = dot(vb, n);  // ua > ub: closing
  for (const auto &[v, before, from, to] :
       {std::tuple{a.v, va, ua, ub}, std::tuple{b.v, vb, ub, ua}}) {
    EXPECT_NEAR(dot(v, n), to, 1e-14);
    const Vec3 tangential = v - dot(v, n) * n, was = before - from * n;
    EXPECT_NEAR(norm(tangential - was), 0.0, 1e-14);
  }
  // J = m (ua - ub), along -n on a; n . (x_a - x_b) = -D.
  EXPECT_NEAR(touch.virial, sphere.mass * (ua - ub) * sphere.diameter, 1e-14);
  // Parting, they are left alone, and the gap is reported.
  Flight c = a, d = b;
  const exact_events::Touch apart = exact_events::give_impulse(c, d, d.x, sphere);
  EXPECT_FALSE(apart.closing);
  EXPECT_EQ(c.v.x, a.v.x);
  EXPECT_NEAR(apart.gap, 0.0, 1e-14);
}

TEST(ExactCollisions, ANewtonsCradleChainsThroughBodiesOutsideTheCandidates) {
  const Shape sphere{.length = 0.0};
  const Box box{{30.0, 20.0, 20.0}};
  const double dt = 0.01;
  // 0 hits 1 early; 1 then moves fast enough to reach 2, which no candidate of the step's
  // start involves (2 is 0.05 D from 1, beyond both bodies' free flights of 0.01 D): the
  // overrun check must join 2 in.
  Particles p = spheres_on_x({5.0, 6.0005, 7.03}, {1.0, 0.0, 0.0});
  const Step s = exact_step(p, box, sphere, dt * 5.0);
  EXPECT_EQ(s.stats.collisions, 2) << "regrown " << s.stats.regrown;
  EXPECT_GE(s.stats.regrown, 1);
  EXPECT_NEAR(p.vx[0], 0.0, 1e-15);
  EXPECT_NEAR(p.vx[1], 0.0, 1e-15);
  EXPECT_NEAR(p.vx[2], 1.0, 1e-15);
  EXPECT_GT(p.x[2] - p.x[1], 1.0 - 1e-12);
}

TEST(ExactCollisions, PastTheEventCapTheClusterIsSolvedTogetherAndCounted) {
  const Shape sphere{.length = 0.0};
  const Box box{{30.0, 20.0, 20.0}};
  // A touching row hit at one end. With no events allowed the cluster falls back to the
  // simultaneous solver at its first contact, the whole row touching: momentum is kept, the
  // energy not gained (the simultaneous solver is not the sequence of elastic collisions).
  Particles p = spheres_on_x({5.0, 6.0 + 1e-11, 7.0 + 2e-11, 8.0 + 3e-11}, {1.0, 0.0, 0.0, 0.0});
  ExactSettings settings;
  settings.events_per_body = 0;
  const Step s = exact_step(p, box, sphere, 0.01, settings);
  EXPECT_EQ(s.stats.fallbacks, 1);
  double momentum = 0.0, energy = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    momentum += p.vx[i];
    energy += 0.5 * p.vx[i] * p.vx[i];
  }
  EXPECT_NEAR(momentum, 1.0, 1e-12);
  EXPECT_LE(energy, 0.5 + 1e-12);
  EXPECT_GE(s.stats.collisions, 3);
  for (std::size_t i = 0; i + 1 < p.size(); ++i) EXPECT_GT(p.x[i + 1] - p.x[i], 1.0 - 1e-9);
}

TEST(ExactCollisions, RodsKeepMomentumAngularMomentumAndEnergy) {
  const Shape rod{.length = 5.0};
  const Box box{{40.0, 40.0, 40.0}};
  // A rod sliding end-first into the middle of another, off centre, so both turn.
  Particles p;
  p.resize(2);
  p.id = {0, 1};
  p.set_position(0, {10.0, 10.0, 10.0});
  p.set_axis(0, {1.0, 0.0, 0.0});
  p.set_velocity(0, {0.0, 0.0, 0.0});
  p.set_position(1, {10.7, 10.0 + 3.5 + 0.003, 10.0});
  p.set_axis(1, {0.0, 1.0, 0.0});
  p.set_velocity(1, {0.0, -1.0, 0.0});
  p.set_angular_velocity(1, {0.0, 0.0, 0.2});
  const double inertia = rod.inertia_perp();
  const auto totals = [&](Vec3 &momentum, Vec3 &angular, double &energy) {
    momentum = p.velocity(0) + p.velocity(1);
    angular = cross(p.position(0), p.velocity(0)) + cross(p.position(1), p.velocity(1)) +
              inertia * (p.angular_velocity(0) + p.angular_velocity(1));
    energy = 0.5 * (norm2(p.velocity(0)) + norm2(p.velocity(1))) +
             0.5 * inertia * (norm2(p.angular_velocity(0)) + norm2(p.angular_velocity(1)));
  };
  Vec3 m0, l0, m1, l1;
  double e0 = 0.0, e1 = 0.0;
  totals(m0, l0, e0);
  const Step s = exact_step(p, box, rod, 0.01);
  totals(m1, l1, e1);
  EXPECT_EQ(s.stats.collisions, 1);
  EXPECT_LT(norm(m1 - m0), 1e-14);
  EXPECT_LT(norm(l1 - l0), 1e-12);
  EXPECT_NEAR(e1, e0, 1e-14);
  EXPECT_LT(s.stats.root_iterations, 20);
}

// The clusters' labels (the root of a union-find, the smallest index) of candidates and joins.
std::vector<std::int64_t> labels(std::size_t n, const std::vector<Candidate> &candidates,
                                 const std::vector<BodyPair> &joins) {
  std::vector<std::uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  const auto root = [&](std::uint32_t a) {
    while (parent[a] != a) a = parent[a];
    return a;
  };
  const auto join = [&](std::uint32_t a, std::uint32_t b) {
    a = root(a), b = root(b);
    parent[std::max(a, b)] = std::min(a, b);
  };
  std::vector<char> in(n, 0);
  for (const Candidate &c : candidates) join(c.i, c.j), in[c.i] = in[c.j] = 1;
  for (const auto &[a, b] : joins) join(a, b), in[a] = in[b] = 1;
  std::vector<std::int64_t> label(n, -1);
  for (std::uint32_t b = 0; b < n; ++b)
    if (in[b]) label[b] = root(b);
  return label;
}

bool same_bits(const FlownBody &a, const FlownBody &b) {
  const auto eq = [](const Vec3 &x, const Vec3 &y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return a.body == b.body && eq(a.x, b.x) && eq(a.e, b.e) && eq(a.v, b.v) && eq(a.w, b.w) &&
         std::memcmp(&a.overrun, &b.overrun, sizeof a.overrun) == 0 &&
         a.collisions == b.collisions && a.virial.raw() == b.virial.raw();
}

// Several ranks solve a step in rounds: every cluster once (collide_once, by cluster or in one
// queue), the overruns' reaches (overrun_reaches) joined, again until none. On one rank that
// must end where collide_exactly's own loop ends, bit for bit: a Newton's cradle (a join), and
// a hot, dense hard-sphere system at a long step (many clusters, several joins).
TEST(ExactCollisions, RoundsOfOnePassAndJoinsEndWhereTheKernelsLoopEnds) {
  const Shape sphere{.length = 0.0};
  Particles cradle = spheres_on_x({5.0, 6.0005, 7.03, 8.2}, {1.0, 0.0, 0.0, -0.5});
  // A hot gas relaxed by the exact method, then one step four times longer (8 joins).
  Scene hot = testing::hard_spheres(10, 0.30, 1e-3);
  hot.method = kExact;
  hot.temperature = 25.0;
  System relax(hot);
  relax.advance(100);
  const struct {
    Particles p;
    Box box;
    double dt;
  } cases[] = {{cradle, Box{{30.0, 20.0, 20.0}}, 0.05}, {relax.particles(), hot.box, 4e-3}};
  long long joined = 0;
  for (const auto &c : cases) {
    Particles p = c.p;
    NeighborList list;
    list.skin = 1.0;
    build_neighbor_list(list, p, p.size(), c.box, sphere);
    refresh_motion(p, p.size(), sphere, 0.5 * c.dt);
    grow_bounds(p, p.size());
    std::vector<Candidate> candidates;
    const StepAhead ahead{p.grow.data(), c.dt};
    detect_candidates(p, c.box, sphere, list, candidates, ahead);
    ExactScratch scratch;
    std::vector<FlownBody> kernel, rounds;
    const ExactStats whole =
        collide_exactly(p, c.box, sphere, list, candidates, c.dt, {}, scratch, kernel);
    const auto by_body = [](const FlownBody &a, const FlownBody &b) { return a.body < b.body; };
    std::sort(kernel.begin(), kernel.end(), by_body);
    // The rounds by cluster, and in one queue (confined to the candidates' and joins' bodies).
    for (const bool queue : {false, true}) {
      ExactSettings settings;
      settings.one_queue = queue;
      std::vector<BodyPair> joins;
      std::vector<double> overrun;
      for (int round = 0; round < 100; ++round) {
        collide_once(p, c.box, sphere, list, candidates, joins, c.dt, settings, scratch, rounds);
        const auto more = overrun_reaches(p, c.box, sphere, list, rounds,
                                          labels(p.size(), candidates, joins), overrun);
        if (more.empty()) break;
        joins.insert(joins.end(), more.begin(), more.end());
      }
      if (!queue) {
        EXPECT_EQ(static_cast<long long>(joins.size()), whole.regrown);
      }
      std::sort(rounds.begin(), rounds.end(), by_body);
      ASSERT_EQ(kernel.size(), rounds.size()) << "queue " << queue;
      EXPECT_GT(kernel.size(), 2u);
      for (std::size_t k = 0; k < kernel.size(); ++k)
        EXPECT_TRUE(same_bits(kernel[k], rounds[k]))
            << "body " << kernel[k].body << " queue " << queue;
    }
    joined += whole.regrown;
  }
  EXPECT_GE(joined, 2);
}

// One rank takes its candidates in the threads' order (StepAhead::canonical false): a
// cluster's events are ordered by time and ids, not by the order its candidates were
// predicted in. Candidates in canonical order, reversed and shuffled give the same step to the
// bit: a hot hard-sphere gas at a long step (joins), and a relaxed nematic.
TEST(ExactCollisions, TheCandidatesOrderDoesNotChangeTheStep) {
  Scene hot = testing::hard_spheres(10, 0.30, 1e-3);
  hot.method = kExact;
  hot.temperature = 25.0;
  Scene rods = testing::small_nematic(1e-3);
  rods.method = kExact;
  long long collisions = 0, regrown = 0;
  for (const auto &[scene, dt] : {std::pair{hot, 4e-3}, std::pair{rods, 4e-3}}) {
    System relax(scene);
    relax.advance(100);
    Particles p = relax.particles();
    NeighborList list;
    list.skin = 1.0;
    build_neighbor_list(list, p, p.size(), scene.box, scene.shape);
    refresh_motion(p, p.size(), scene.shape, 0.5 * dt);
    grow_bounds(p, p.size());
    std::vector<Candidate> canonical, threads_order;
    NeighborList again = list;
    detect_candidates(p, scene.box, scene.shape, list, canonical, StepAhead{p.grow.data(), dt});
    detect_candidates(p, scene.box, scene.shape, again, threads_order,
                      StepAhead{p.grow.data(), dt, false});
    ASSERT_EQ(threads_order.size(), canonical.size());
    std::vector<Candidate> reversed(canonical.rbegin(), canonical.rend()), shuffled = canonical;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(7));
    ExactScratch scratch;
    std::vector<FlownBody> want;
    const ExactStats base =
        collide_exactly(p, scene.box, scene.shape, list, canonical, dt, {}, scratch, want);
    const auto by_body = [](const FlownBody &a, const FlownBody &b) { return a.body < b.body; };
    std::sort(want.begin(), want.end(), by_body);
    for (const std::vector<Candidate> *order : {&threads_order, &reversed, &shuffled}) {
      std::vector<FlownBody> got;
      const ExactStats other =
          collide_exactly(p, scene.box, scene.shape, list, *order, dt, {}, scratch, got);
      EXPECT_EQ(other.collisions, base.collisions);
      EXPECT_EQ(other.events, base.events);
      EXPECT_EQ(other.searches, base.searches);
      EXPECT_EQ(other.regrown, base.regrown);
      EXPECT_EQ(other.virial.raw(), base.virial.raw());
      std::sort(got.begin(), got.end(), by_body);
      ASSERT_EQ(got.size(), want.size());
      for (std::size_t k = 0; k < got.size(); ++k)
        EXPECT_TRUE(same_bits(got[k], want[k])) << "body " << got[k].body;
    }
    collisions += base.collisions;
    regrown += base.regrown;
  }
  EXPECT_GT(collisions, 20) << "the test must exercise collisions";
  EXPECT_GT(regrown, 0) << "the test must exercise joins";
}

// One rank takes a step's events in one queue (ExactSettings::one_queue): the same events as
// the clusters', so the same end states to the bit, with or without an overrun allowance (the
// detection's spares). A Newton's cradle whose third body only a body's overrun brings in (an
// extra pair, or a spare); two cradles whose middle bodies, at rest, meet only because both
// overrun, one by more than the allowance 0.1 dt and one by less (the first's check must count
// the second's as the allowance); a hot, dense hard-sphere gas at a long step (the clusters
// join), a relaxed nematic at a long step, and a row past the event cap, where the queue gives
// up and the clusters' fallback solves the step.
TEST(ExactCollisions, TheOneQueueEndsWhereTheClustersEnd) {
  const Shape sphere{.length = 0.0};
  Scene hot = testing::hard_spheres(10, 0.30, 1e-3);
  hot.method = kExact;
  hot.temperature = 25.0;
  System hot_relaxed(hot);
  hot_relaxed.advance(100);
  Scene rods = testing::small_nematic(1e-3);
  rods.method = kExact;
  System rods_relaxed(rods);
  rods_relaxed.advance(100);
  const struct {
    Particles p;
    Box box;
    Shape shape;
    double dt;
    long events_per_body;
  } cases[] = {
      {spheres_on_x({5.0, 6.0005, 7.03}, {1.0, 0.0, 0.0}), Box{{30.0, 20.0, 20.0}}, sphere, 0.05,
       100},
      {spheres_on_x({5.0, 6.075, 7.105, 8.197}, {1.0, 0.0, 0.0, -1.0}), Box{{30.0, 20.0, 20.0}},
       sphere, 0.1, 100},
      {hot_relaxed.particles(), hot.box, sphere, 4e-3, 100},
      {rods_relaxed.particles(), rods.box, rods.shape, 4e-3, 100},
      {spheres_on_x({5.0, 6.0 + 1e-11, 7.0 + 2e-11, 8.0 + 3e-11}, {1.0, 0.0, 0.0, 0.0}),
       Box{{30.0, 20.0, 20.0}}, sphere, 0.01, 0},
  };
  const auto by_body = [](const FlownBody &x, const FlownBody &y) { return x.body < y.body; };
  long long extra = 0, spares = 0, collisions = 0, queued = 0, fallbacks = 0, kept = 0;
  for (const auto &c : cases) {
    Particles p = c.p;
    NeighborList built;
    built.skin = 1.0;
    build_neighbor_list(built, p, p.size(), c.box, c.shape);
    refresh_motion(p, p.size(), c.shape, 0.5 * c.dt);
    grow_bounds(p, p.size());
    NeighborList list = built;
    std::vector<Candidate> candidates;
    detect_candidates(p, c.box, c.shape, list, candidates, StepAhead{p.grow.data(), c.dt});
    ExactSettings by_cluster;
    by_cluster.events_per_body = c.events_per_body;
    ExactScratch scratch;
    std::vector<FlownBody> want;
    const ExactStats a =
        collide_exactly(p, c.box, c.shape, list, candidates, c.dt, by_cluster, scratch, want);
    EXPECT_EQ(a.queued, 0);
    std::sort(want.begin(), want.end(), by_body);
    // The allowances: none, ones the cradles' overruns pass, and one they do not.
    for (const double allowance : {0.0, 1e-3 * c.dt, 0.1 * c.dt, 2.0 * c.dt}) {
      NeighborList own = built;
      std::vector<Candidate> found;
      detect_candidates(p, c.box, c.shape, own, found,
                        StepAhead{p.grow.data(), c.dt, true, allowance});
      ExactSettings in_queue = by_cluster;
      in_queue.one_queue = true;
      in_queue.overrun_allowance = allowance;
      std::vector<FlownBody> got;
      const ExactStats b =
          collide_exactly(p, c.box, c.shape, own, found, c.dt, in_queue, scratch, got);
      EXPECT_EQ(b.candidates, a.candidates) << "spares are not candidates";
      EXPECT_EQ(b.apart, a.apart);
      EXPECT_EQ(b.collisions, a.collisions);
      EXPECT_EQ(b.fallbacks, a.fallbacks);
      EXPECT_EQ(b.virial.raw(), a.virial.raw());
      std::sort(got.begin(), got.end(), by_body);
      ASSERT_EQ(got.size(), want.size());
      for (std::size_t k = 0; k < got.size(); ++k)
        EXPECT_TRUE(same_bits(got[k], want[k]))
            << "body " << got[k].body << ", allowance " << allowance;
      extra += b.extra_pairs;
      spares += b.spares;
      collisions += b.collisions;
      queued += b.queued;
      fallbacks += b.fallbacks;
      kept += b.queued > 0 ? b.kept_apart : 0;
    }
  }
  EXPECT_EQ(queued, 4 * 4) << "the row past the cap must leave the queue";
  EXPECT_EQ(fallbacks, 4);
  EXPECT_GE(extra, 2) << "the test must exercise pairs a body's overrun brings in";
  EXPECT_GT(kept, 10) << "and searches a pair's proof made needless (Candidate::proven)";
  EXPECT_GT(spares, 10) << "the test must exercise the allowance's spares";
  EXPECT_GT(collisions, 4 * 40) << "the test must exercise collisions";
}

}  // namespace
namespace {

// The one queue's calendar (exact_events::EventCalendar) must give the events in a heap's
// order (Later: by time, ties by ids) whatever comes: many ties in time and ids, events at
// 0 and at dt, pushes between pops from the time of the last one taken on, now and then one
// earlier than that, a calendar used again for a second step. It fails if a bucket's chain
// gives any but its earliest, or if the buckets' order broke ties of time.
TEST(ExactEvents, TheCalendarGivesTheHeapsOrder) {
  using exact_events::Event;
  using exact_events::EventCalendar;
  using exact_events::Later;
  std::mt19937_64 rng(17);
  const double dt = 4e-3;
  std::uniform_int_distribution<int> grid(0, 64), ids(0, 5), coin(0, 99);
  const auto event = [&](double from) {
    Event e;
    const double u = static_cast<double>(grid(rng)) / 64.0;  // ties in time, 0 and dt included
    e.t = from + u * (dt - from);
    e.id_a = ids(rng);
    e.id_b = e.id_a + 1 + ids(rng);
    e.a = static_cast<std::uint32_t>(rng() % 1000);
    e.version_a = static_cast<std::uint32_t>(rng() % 7);
    return e;
  };
  EventCalendar calendar;
  for (int step = 0; step < 2; ++step) {
    std::vector<Event> heap;
    calendar.start(dt, 400);
    const auto push = [&](const Event &e) {
      calendar.push(e);
      heap.push_back(e);
      std::push_heap(heap.begin(), heap.end(), Later());
    };
    for (int k = 0; k < 400; ++k) push(event(0.0));
    long taken = 0, earlier = 0;
    while (!heap.empty()) {
      ASSERT_FALSE(calendar.empty());
      std::pop_heap(heap.begin(), heap.end(), Later());
      const Event want = heap.back();
      heap.pop_back();
      const Event got = calendar.pop();
      ASSERT_EQ(got.t, want.t) << "event " << taken;
      ASSERT_EQ(got.id_a, want.id_a) << "event " << taken;
      ASSERT_EQ(got.id_b, want.id_b) << "event " << taken;
      ++taken;
      if (taken > 3000) continue;  // then empty both
      for (int k = coin(rng) % 3; k > 0; --k) push(event(got.t));
      if (coin(rng) == 0) {
        push(event(0.5 * got.t));  // earlier than the last one taken
        ++earlier;
      }
    }
    EXPECT_TRUE(calendar.empty());
    EXPECT_GT(taken, 3000);
    EXPECT_GT(earlier, 10) << "the test must push earlier events too";
  }
}

}  // namespace
}  // namespace hardrod
