// The Verlet pair list (kernels/neighbor_list.hpp) against brute force, through its API
// only: a build lists exactly the pairs whose axis segments are closer than D + skin, each
// once, with its slack (segment distance - D - kDistanceSafetyMargin); the watches split
// every slack into two allowances whose sum stays below it, and each body watches its
// smallest; with shadows only pairs with an owned body are kept and the first ring is stored
// right after the owned bodies; and while the bounds stay below the skin, no unlisted pair
// can touch. Rods and spheres, large and small boxes, one and two threads.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <utility>

#include "kernels/neighbor_list.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

using IdPair = std::pair<std::int64_t, std::int64_t>;

// Random bodies (ids not in storage order), axes random or near x.
Particles random_bodies(std::size_t n, const Box &box, std::uint64_t seed, bool aligned) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(3 * (n - i));
    p.set_position(i, {u(rng) * box.length.x, u(rng) * box.length.y, u(rng) * box.length.z});
    const Vec3 e = aligned ? Vec3{1.0, 0.2 * g(rng), 0.2 * g(rng)} : Vec3{g(rng), g(rng), g(rng)};
    p.set_axis(i, (1.0 / norm(e)) * e);
  }
  return p;
}

double segment_distance(const Particles &p, std::size_t i, std::size_t j, const Box &box,
                        const Shape &shape) {
  const Vec3 r = box.minimum_image(p.position(j) - p.position(i));
  const double h = shape.half_length();
  return std::sqrt(segment_closest(r, p.axis(i), h, p.axis(j), h).dist2);
}

IdPair ids(const Particles &p, std::uint32_t a, std::uint32_t b) {
  return {std::min(p.id[a], p.id[b]), std::max(p.id[a], p.id[b])};
}

// Brute force: every pair closer than `reach`, by id, with its segment distance.
std::map<IdPair, double> pairs_within(const Particles &p, const Box &box, const Shape &shape,
                                      double reach) {
  std::map<IdPair, double> out;
  for (std::uint32_t i = 0; i < p.size(); ++i)
    for (std::uint32_t j = i + 1; j < p.size(); ++j) {
      const double d = segment_distance(p, i, j, box, shape);
      if (d < reach) out[ids(p, i, j)] = d;
    }
  return out;
}

// The list's pairs by id, each once, with their slack.
std::map<IdPair, double> listed(const NeighborList &list, const Particles &p) {
  std::map<IdPair, double> out;
  for (const ListedPair &pair : list.pairs) {
    EXPECT_NE(pair.first, pair.second);
    EXPECT_TRUE(out.emplace(ids(p, pair.first, pair.second), pair.recheck_at).second)
        << "pair listed twice";
  }
  return out;
}

// The watches as neighbor_list.hpp documents them.
void expect_watches(const NeighborList &list) {
  ASSERT_EQ(list.pairs_start.size(), list.active + 1);
  ASSERT_EQ(list.pair_index.size(), 2 * list.pair_count());
  ASSERT_EQ(list.pair_partner.size(), 2 * list.pair_count());
  ASSERT_EQ(list.watch.size(), list.active);
  EXPECT_TRUE(list.watching);
  std::vector<int> ends(list.pair_count(), 0);
  for (std::uint32_t i = 0; i < list.active; ++i) {
    double smallest = std::numeric_limits<double>::infinity();
    for (std::uint32_t a = list.pairs_start[i]; a < list.pairs_start[i + 1]; ++a) {
      const ListedPair &pair = list.pairs[list.pair_index[a]];
      EXPECT_TRUE(pair.first == i || pair.second == i) << "body " << i << " indexes a pair";
      EXPECT_EQ(list.pair_partner[a], pair.first == i ? pair.second : pair.first)
          << "body " << i << " names its partner";
      ++ends[list.pair_index[a]];
      smallest = std::min(smallest, pair.allowance(i));
    }
    EXPECT_EQ(list.watch[i], smallest) << "body " << i;
  }
  for (std::size_t k = 0; k < list.pair_count(); ++k) {
    const ListedPair &pair = list.pairs[k];
    EXPECT_EQ(ends[k], 2) << "pair " << k << " indexed once per body";
    EXPECT_EQ(pair.allowance_first, 0.5 * pair.recheck_at);  // split evenly at a build
    EXPECT_EQ(pair.second_allowance(),
              double{pair.recheck_at} - double{pair.allowance_first} - kAllowanceCushion);
    EXPECT_LT(pair.allowance_first + pair.second_allowance(), pair.recheck_at);
  }
}

struct Case {
  double length, skin;
  bool aligned;
  bool small;  // a box of one cell per axis (the reduced stencil), still wider than 2 (L + D)
  int threads;
};

class NeighborListMatchesBruteForce : public ::testing::TestWithParam<Case> {};

TEST_P(NeighborListMatchesBruteForce, ExactlyThePairsWithinDPlusSkin) {
  const Case c = GetParam();
  Shape shape;
  shape.length = c.length;
  Box box;
  const double range = c.length + 1.0;
  box.length = c.small ? Vec3{2.1 * range + 0.5, 2.2 * range, 2.3 * range}
                       : Vec3{3.1 * range + 1.0, 2.7 * range + 2.0, 2.9 * range + 1.5};
  const std::size_t n =
      std::max<std::size_t>(20, static_cast<std::size_t>(0.3 * box.volume() / shape.volume()));
  omp_set_num_threads(c.threads);
  Particles p = random_bodies(n, box, 11 + c.threads, c.aligned);
  const std::map<IdPair, double> expected = pairs_within(p, box, shape, shape.diameter + c.skin);
  NeighborList list;
  list.skin = c.skin;
  for (std::size_t i = 0; i < n; ++i) p.motion_bound[i] = 0.1;
  build_neighbor_list(list, p, n, box, shape);
  omp_set_num_threads(1);

  const std::map<IdPair, double> got = listed(list, p);
  EXPECT_EQ(got.size(), expected.size());
  for (const auto &[pair, d] : expected) {
    const auto it = got.find(pair);
    ASSERT_NE(it, got.end()) << "missing " << pair.first << "-" << pair.second << " at " << d;
    // Stored as a float rounded down (slack_below): at most two float roundings below the
    // distance's slack, never above it (beyond the distances' own rounding, 1e-12).
    const double want = d - shape.diameter - kDistanceSafetyMargin;
    EXPECT_LE(it->second, want + 1e-12);
    EXPECT_GE(it->second, want - 1e-12 - 2.4e-7 * std::abs(want));
  }
  for (const auto &[pair, slack] : got)
    EXPECT_TRUE(expected.count(pair)) << "extra " << pair.first << "-" << pair.second;
  EXPECT_GT(expected.size(), n / 4) << "the test must list pairs";

  EXPECT_EQ(list.cells.full_stencil, !c.small) << "the case must take the path it names";
  EXPECT_EQ(list.builds, 1);
  EXPECT_EQ(list.bodies, n);
  EXPECT_EQ(list.active, n);
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(p.motion_bound[i], 0.0) << "bound not reset";
  expect_watches(list);
}

INSTANTIATE_TEST_SUITE_P(
    Shapes, NeighborListMatchesBruteForce,
    ::testing::Values(Case{5.0, 0.3, true, false, 1}, Case{5.0, 0.3, false, false, 2},
                      Case{5.0, 0.8, true, true, 1}, Case{0.0, 0.3, false, false, 2},
                      Case{0.0, 0.5, false, true, 1}, Case{1.0, 0.05, false, false, 2}),
    [](const ::testing::TestParamInfo<Case> &info) {
      const Case &c = info.param;
      std::string name = "L";  // appended piecewise: GCC 12 warns falsely on "L" + std::string
      name += std::to_string(static_cast<int>(c.length));
      name += "_skin" + std::to_string(static_cast<int>(c.skin * 100));
      name += c.aligned ? "_aligned" : "_random";
      name += c.small ? "_small" : "_large";
      name += "_threads" + std::to_string(c.threads);
      return name;
    });

// Pairs placed at the reach within a part in 10^7, side by side (where the preselection's
// bound is tight) or crossing, their closest points inside both segments, far from the
// origin of a large box: those just inside are listed, those just outside not, exactly as
// brute force says. The rods' preselection runs in single precision (rounding ~1e-6 D at L/D 5)
// with a margin over the reach; without the margin the side-by-side pairs just inside are
// lost.
TEST(NeighborList, PairsAtTheReachAreListedAsBruteForceSays) {
  for (const double length : {5.0, 100.0, 1000.0}) {
    Shape shape;
    shape.length = length;
    const double h = shape.half_length(), skin = 0.4, reach = shape.diameter + skin;
    Box box;
    const double side = 6.0 * (length + reach);
    box.length = {side, 1.1 * side, 1.2 * side};
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> g(0.0, 1.0);
    const auto unit = [&] {
      const Vec3 v{g(rng), g(rng), g(rng)};
      return (1.0 / norm(v)) * v;
    };
    const std::size_t pairs = 200;
    Particles p;
    p.resize(2 * pairs);
    for (std::size_t k = 0; k < pairs; ++k) {
      const Vec3 ei = unit();
      const bool parallel = k % 2 == 0;
      const Vec3 ej = parallel ? ei : unit();
      Vec3 n = cross(ei, ej);
      if (parallel) n = cross(ei, unit());
      n = (1.0 / norm(n)) * n;
      // Closest points at arms s on i and t on j, the segments' distance d along n.
      const double s = (2.0 * u(rng) - 1.0) * 0.9 * h, t = (2.0 * u(rng) - 1.0) * 0.9 * h;
      const double d = reach * (k % 4 < 2 ? 1.0 - 1e-7 : 1.0 + 1e-7);
      const Vec3 xi{(0.5 + 0.5 * u(rng)) * box.length.x, (0.5 + 0.5 * u(rng)) * box.length.y,
                    (0.5 + 0.5 * u(rng)) * box.length.z};
      const Vec3 xj = xi + s * ei + d * n - t * ej;
      p.id[2 * k] = static_cast<std::int64_t>(2 * k);
      p.id[2 * k + 1] = static_cast<std::int64_t>(2 * k + 1);
      p.set_position(2 * k, xi);
      p.set_axis(2 * k, ei);
      p.set_position(2 * k + 1, box.wrap(xj));
      p.set_axis(2 * k + 1, ej);
    }
    const std::map<IdPair, double> expected = pairs_within(p, box, shape, reach);
    NeighborList list;
    list.skin = skin;
    build_neighbor_list(list, p, p.size(), box, shape);
    ASSERT_TRUE(list.cells.full_stencil) << "the preselection runs with the full stencil only";
    const std::map<IdPair, double> got = listed(list, p);
    for (const auto &[pair, d] : expected)
      EXPECT_TRUE(got.count(pair)) << "L " << length << ": missing " << pair.first << "-"
                                   << pair.second << " at " << d - reach << " from the reach";
    for (const auto &[pair, slack] : got)
      EXPECT_TRUE(expected.count(pair))
          << "L " << length << ": extra " << pair.first << "-" << pair.second;
    int inside = 0;  // by id: the build sorts the bodies
    for (std::int64_t k = 0; k < static_cast<std::int64_t>(pairs); ++k)
      inside += expected.count({2 * k, 2 * k + 1}) > 0;
    EXPECT_EQ(inside, static_cast<int>(pairs / 2)) << "L " << length << ": the placed pairs";
  }
}

// The promise of the skin: move every body by less than a bound b (here a translation of
// length b, so its motion bound is b); while 2 b < skin, every pair closer than D is listed.
TEST(NeighborList, UnlistedPairsCannotTouchWhileTheBoundsStayBelowTheSkin) {
  Shape shape;
  Box box;
  box.length = {20.0, 21.0, 22.0};
  const std::size_t n = 500;
  Particles p = random_bodies(n, box, 5, true);
  NeighborList list;
  list.skin = 0.4;
  build_neighbor_list(list, p, n, box, shape);
  const std::map<IdPair, double> got = listed(list, p);
  std::mt19937_64 rng(6);
  std::normal_distribution<double> g(0.0, 1.0);
  const double b = 0.199;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 dir{g(rng), g(rng), g(rng)};
    p.set_position(i, p.position(i) + (b / norm(dir)) * dir);
    p.motion_bound[i] = b;
  }
  EXPECT_FALSE(neighbor_list_expired(list, largest_motion_bound(p, n), n));
  int touching = 0;
  for (const auto &[pair, d] : pairs_within(p, box, shape, shape.diameter)) {
    ++touching;
    EXPECT_TRUE(got.count(pair)) << "unlisted pair " << pair.first << "-" << pair.second
                                 << " touches at " << d;
  }
  EXPECT_GT(touching, 0) << "the test must move bodies into contact";
}

TEST(NeighborList, ExpiresWhenTwiceTheLargestBoundReachesTheSkin) {
  NeighborList list;
  list.skin = 0.3;
  EXPECT_TRUE(neighbor_list_expired(list, 0.0, 10)) << "never built";
  list.builds = 1;
  list.bodies = 10;
  EXPECT_FALSE(neighbor_list_expired(list, 0.0, 10));
  EXPECT_FALSE(neighbor_list_expired(list, 0.149, 10));
  EXPECT_TRUE(neighbor_list_expired(list, 0.15, 10));
  EXPECT_TRUE(neighbor_list_expired(list, 0.0, 11)) << "built for another body count";

  Particles p;
  p.resize(4);
  p.motion_bound = {0.1, 0.7, 0.3, 0.9};
  EXPECT_EQ(largest_motion_bound(p, 4), 0.9);
  EXPECT_EQ(largest_motion_bound(p, 3), 0.7);
  EXPECT_EQ(largest_motion_bound(p, 0), 0.0);
}

// A stored slack is never above the double it came from, and is within two of a float's
// roundings of it: a pair is measured no later than its double slack says, and hardly earlier.
TEST(NeighborList, SlacksAreStoredRoundedDown) {
  for (const double x : {0.1, -0.1, 0.3, 1.0 / 3.0, -1e-9, 2.5e-7, 7.123456789, 0.0, 0.5, 1e-50,
                         -1e-50, -0.75, -1.0 / 3.0, 1e-40, -1e-40, 9.99}) {
    const float f = slack_below(x);
    EXPECT_LE(double{f}, x) << x;
    EXPECT_GE(double{f}, x - 2.4e-7 * std::abs(x) - 1e-29) << x;
  }
  EXPECT_LT(double{slack_below(0.5)}, 0.5) << "a float is stored below itself too";
  EXPECT_TRUE(std::isnan(slack_below(std::nan(""))));
  EXPECT_EQ(sizeof(ListedPair), 16u);
}

// With shadows: pairs between two shadows are dropped, the owned bodies keep [0, owned), the
// shadows in a kept pair (the first ring) follow them up to `active`, the rest come after.
TEST(NeighborList, ShadowsKeepOnlyPairsWithAnOwnedBodyAndTheFirstRing) {
  Shape shape;
  Box box;
  box.length = {24.0, 22.0, 23.0};
  const std::size_t n = 700;
  Particles p = random_bodies(n, box, 9, false);
  // Owned: the bodies with x below 8, stored first; the rest are shadows.
  std::vector<std::uint32_t> order;
  for (std::uint32_t pass = 0; pass < 2; ++pass)
    for (std::uint32_t i = 0; i < n; ++i)
      if ((p.x[i] < 8.0) == (pass == 0)) order.push_back(i);
  p.permute(order);
  std::size_t owned = 0;
  while (owned < n && p.x[owned] < 8.0) ++owned;
  const std::set<std::int64_t> owned_ids(p.id.begin(), p.id.begin() + static_cast<long>(owned));

  std::map<IdPair, double> expected;
  for (const auto &[pair, d] : pairs_within(p, box, shape, shape.diameter + 0.3))
    if (owned_ids.count(pair.first) || owned_ids.count(pair.second)) expected[pair] = d;
  std::set<std::int64_t> ring;
  for (const auto &[pair, d] : expected)
    for (const std::int64_t id : {pair.first, pair.second})
      if (!owned_ids.count(id)) ring.insert(id);

  NeighborList list;
  build_neighbor_list(list, p, n, owned, box, shape);
  const std::map<IdPair, double> got = listed(list, p);
  EXPECT_EQ(got.size(), expected.size());
  for (const auto &[pair, d] : expected) EXPECT_TRUE(got.count(pair)) << pair.first;
  EXPECT_EQ(std::set<std::int64_t>(p.id.begin(), p.id.begin() + static_cast<long>(owned)),
            owned_ids);
  ASSERT_EQ(list.active, owned + ring.size());
  EXPECT_EQ(std::set<std::int64_t>(p.id.begin() + static_cast<long>(owned),
                                   p.id.begin() + static_cast<long>(list.active)),
            ring);
  for (const ListedPair &pair : list.pairs) {
    EXPECT_LT(pair.first, list.active);
    EXPECT_LT(pair.second, list.active);
    EXPECT_TRUE(pair.first < owned || pair.second < owned);
  }
  EXPECT_GT(ring.size(), 0u);
  EXPECT_LT(list.active, n) << "the test must have shadows beyond the first ring";
  expect_watches(list);
}

// arm_watches again after editing the slacks (as a test of the detection does).
TEST(NeighborList, ArmWatchesFollowsEditedSlacks) {
  Shape shape;
  Box box;
  box.length = {18.0, 19.0, 20.0};
  Particles p = random_bodies(300, box, 13, true);
  NeighborList list;
  build_neighbor_list(list, p, p.size(), box, shape);
  ASSERT_GT(list.pair_count(), 10u);
  for (std::size_t k = 0; k < list.pair_count(); k += 3) list.pairs[k].recheck_at *= 0.25;
  arm_watches(list);
  expect_watches(list);
}

}  // namespace
}  // namespace hardrod
