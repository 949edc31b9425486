// A neighbour list extended body by body (kernels/exact/list_extension.hpp), against brute force:
// after bodies move (each by at most its motion bound) and the ones at or past their reach are
// extended, every pair the list does not hold was, at the build, at least D + reach_a +
// reach_b apart, so that none can touch while each bound stays below its reach; each pair is
// listed once, the new ones due at once; the by-body index names every pair at both of its
// bodies. Spheres and rods; an extension that would pass its budget, of a runaway body, or of
// a list with shadows changes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>

#include "kernels/exact/list_extension.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

using IdPair = std::pair<std::int64_t, std::int64_t>;

struct Fluid {
  Shape shape;
  Box box;
  Particles p;
  NeighborList list;
  ListExtension ext;
};

// Random bodies at a fifth of close packing, the list built with skin 0.5.
Fluid built(double length, std::uint64_t seed) {
  Fluid s;
  s.shape.length = length;
  const double range = length > 0.0 ? length + 1.5 : 4.5;  // ~700 rods, ~2000 spheres
  s.box.length = {4.1 * range, 3.7 * range, 3.9 * range};
  const auto n = static_cast<std::size_t>(0.2 * s.box.volume() / s.shape.volume());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  s.p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.p.id[i] = static_cast<std::int64_t>(5 * (n - i));
    s.p.set_position(i,
                     {u(rng) * s.box.length.x, u(rng) * s.box.length.y, u(rng) * s.box.length.z});
    const Vec3 e{1.0 + g(rng), 0.5 * g(rng), 0.5 * g(rng)};
    s.p.set_axis(i, (1.0 / norm(e)) * e);
  }
  s.list.skin = 0.5;
  build_neighbor_list(s.list, s.p, n, s.box, s.shape);
  start_extension(s.ext, s.list, s.p, n, s.shape);
  return s;
}

// Every body moved by a random translation and turn, its bound set to what that moved any
// point of it (|dx| + h |de|): most within half the skin, one in eight up to 2.5 times it.
void move(Fluid &s, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  const double h = s.shape.half_length(), half = 0.5 * s.list.skin;
  for (std::size_t i = 0; i < s.p.size(); ++i) {
    const double size = (u(rng) < 0.125 ? 2.5 : 0.9) * half * u(rng);
    Vec3 dx{g(rng), g(rng), g(rng)};
    dx = (size / norm(dx)) * dx;
    Vec3 e = s.p.axis(i) + Vec3{0.02 * g(rng), 0.02 * g(rng), 0.02 * g(rng)};
    e = (1.0 / norm(e)) * e;
    const double moved = norm(dx) + h * norm(e - s.p.axis(i));
    s.p.set_position(i, s.p.position(i) + dx);
    s.p.set_axis(i, e);
    s.p.motion_bound[i] = moved * (1.0 + 1e-12);
  }
}

double segment_distance(const Vec3 &xi, const Vec3 &ei, const Vec3 &xj, const Vec3 &ej,
                        const Box &box, double h) {
  const Vec3 r = box.minimum_image(xj - xi);
  return std::sqrt(segment_closest(r, ei, h, ej, h).dist2);
}

std::map<IdPair, std::uint32_t> listed(const Fluid &s) {
  std::map<IdPair, std::uint32_t> out;
  for (std::uint32_t k = 0; k < s.list.pair_count(); ++k) {
    const ListedPair &pair = s.list.pairs[k];
    const IdPair ids{std::min(s.p.id[pair.first], s.p.id[pair.second]),
                     std::max(s.p.id[pair.first], s.p.id[pair.second])};
    EXPECT_TRUE(out.emplace(ids, k).second) << "pair listed twice";
  }
  return out;
}

// Each body's run of the index names exactly the pairs it is in, with the partner.
void expect_index(const NeighborList &list) {
  ASSERT_EQ(list.pairs_end.size(), list.active);
  std::vector<std::multiset<std::uint32_t>> expected(list.active), got(list.active);
  for (std::uint32_t k = 0; k < list.pair_count(); ++k) {
    expected[list.pairs[k].first].insert(k);
    expected[list.pairs[k].second].insert(k);
  }
  for (std::uint32_t b = 0; b < list.active; ++b) {
    for (std::uint32_t q = list.pairs_start[b]; q < list.pairs_end[b]; ++q) {
      const ListedPair &pair = list.pairs[list.pair_index[q]];
      EXPECT_EQ(list.pair_partner[q], pair.first == b ? pair.second : pair.first) << "body " << b;
      got[b].insert(list.pair_index[q]);
    }
    EXPECT_EQ(got[b], expected[b]) << "body " << b;
  }
}

class ListExtension : public ::testing::TestWithParam<double> {};

TEST_P(ListExtension, NoPairLeftOutCanTouchWhileEachBoundIsBelowItsReach) {
  Fluid s = built(GetParam(), 7);
  const std::size_t n = s.p.size();
  const double h = s.shape.half_length(), D = s.shape.diameter, half = 0.5 * s.list.skin;
  const Particles at_build = s.p;
  const std::size_t built_pairs = s.list.pair_count();
  move(s, 8);
  std::size_t past = 0;
  for (std::size_t i = 0; i < n; ++i) past += !(s.p.motion_bound[i] < half);
  ASSERT_GT(past, 10u);

  s.list.near.valid = true;  // near pairs in use (NearPairs): the new ones join them
  s.list.near.index = {0, 2};
  ASSERT_TRUE(extend_neighbor_list(s.list, s.ext, s.p, s.box, s.shape, 0.0, 1 << 30));
  EXPECT_EQ(s.ext.extended, static_cast<long long>(past));
  ASSERT_EQ(s.list.near.index.size(), 2 + s.list.pair_count() - built_pairs);
  for (std::size_t k = 2; k < s.list.near.index.size(); ++k)
    EXPECT_EQ(s.list.near.index[k], built_pairs + k - 2);
  EXPECT_FALSE(s.list.watching);
  EXPECT_GT(s.list.pair_count(), built_pairs);
  for (std::uint32_t k = static_cast<std::uint32_t>(built_pairs); k < s.list.pair_count(); ++k)
    EXPECT_EQ(s.list.pairs[k].recheck_at, -std::numeric_limits<float>::infinity()) << "due";
  const auto reach = [&](std::size_t i) { return half + s.ext.extra_reach[i]; };
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_LT(s.p.motion_bound[i], reach(i)) << "body " << i;
    EXPECT_EQ(s.ext.extra_reach[i] > 0.0, !(s.p.motion_bound[i] < half)) << "body " << i;
  }
  // Every pair within D + reach_a + reach_b at the build is listed.
  const auto expect_complete = [&]() {
    const std::map<IdPair, std::uint32_t> got = listed(s);
    std::size_t close = 0;
    for (std::uint32_t i = 0; i < n; ++i)
      for (std::uint32_t j = i + 1; j < n; ++j) {
        const double d = segment_distance(at_build.position(i), at_build.axis(i),
                                          at_build.position(j), at_build.axis(j), s.box, h);
        if (!(d < D + reach(i) + reach(j))) continue;
        ++close;
        EXPECT_TRUE(got.count({std::min(s.p.id[i], s.p.id[j]), std::max(s.p.id[i], s.p.id[j])}))
            << "bodies " << i << ", " << j << " at " << d << " at the build, reaches " << reach(i)
            << " and " << reach(j);
      }
    return close;
  };
  EXPECT_GT(expect_complete(), built_pairs);  // the reaches did grow the pairs needed
  expect_index(s.list);

  // A second round: the same bodies moved on, extended again from their new reaches.
  const std::size_t before = s.list.pair_count();
  for (std::size_t i = 0; i < n; ++i) s.p.motion_bound[i] += 0.5 * half;
  ASSERT_TRUE(extend_neighbor_list(s.list, s.ext, s.p, s.box, s.shape, 0.0, 1 << 30));
  EXPECT_GT(s.list.pair_count(), before);
  for (std::size_t i = 0; i < n; ++i) EXPECT_LT(s.p.motion_bound[i], reach(i));
  expect_complete();
  expect_index(s.list);
}

INSTANTIATE_TEST_SUITE_P(SpheresAndRods, ListExtension, ::testing::Values(0.0, 5.0),
                         [](const ::testing::TestParamInfo<double> &info) {
                           return info.param > 0.0 ? std::string("rods") : std::string("spheres");
                         });

TEST(ListExtensionLimits, PastItsBudgetOrWithShadowsNothingChanges) {
  Fluid s = built(0.0, 3);
  move(s, 4);
  const std::size_t pairs = s.list.pair_count();
  EXPECT_FALSE(extend_neighbor_list(s.list, s.ext, s.p, s.box, s.shape, 0.0, 3));
  EXPECT_EQ(s.list.pair_count(), pairs);
  EXPECT_EQ(s.ext.extended, 0);
  for (const double e : s.ext.extra_reach) EXPECT_EQ(e, 0.0);

  // The lead counts: with none of the bounds past half the skin, a lead as large extends
  // every body.
  Fluid t = built(0.0, 5);
  EXPECT_TRUE(extend_neighbor_list(t.list, t.ext, t.p, t.box, t.shape, 0.0, 0));  // nothing due
  EXPECT_EQ(t.ext.extended, 0);
  EXPECT_TRUE(extend_neighbor_list(t.list, t.ext, t.p, t.box, t.shape, 0.5 * t.list.skin, 1 << 30));
  EXPECT_EQ(t.ext.extended, static_cast<long long>(t.p.size()));

  // A runaway (a bound past twice the skin) or a NaN is left to the build.
  Fluid v = built(0.0, 8);
  v.p.motion_bound[5] = 2.0 * v.list.skin;
  EXPECT_FALSE(extend_neighbor_list(v.list, v.ext, v.p, v.box, v.shape, 0.0, 1 << 30));
  v.p.motion_bound[5] = std::nan("");
  EXPECT_FALSE(extend_neighbor_list(v.list, v.ext, v.p, v.box, v.shape, 0.0, 1 << 30));
  EXPECT_EQ(v.ext.extended, 0);

  // A list whose build's state was not kept (the midpoint method's) is not extended.
  Fluid w = built(0.0, 9);
  build_neighbor_list(w.list, w.p, w.p.size(), w.box, w.shape);
  w.ext = hardrod::ListExtension();
  move(w, 10);
  EXPECT_FALSE(extend_neighbor_list(w.list, w.ext, w.p, w.box, w.shape, 0.0, 1 << 30));

  // Shadows (several ranks): bodies [owned, count) are other ranks' copies.
  Fluid u = built(0.0, 6);
  const std::size_t n = u.p.size();
  build_neighbor_list(u.list, u.p, n, n - 20, u.box, u.shape);
  start_extension(u.ext, u.list, u.p, n - 20, u.shape);
  EXPECT_TRUE(u.ext.built.x.empty());
  move(u, 7);
  EXPECT_FALSE(extend_neighbor_list(u.list, u.ext, u.p, u.box, u.shape, 0.0, 1 << 30));
  EXPECT_EQ(u.ext.extended, 0);
}

}  // namespace
}  // namespace hardrod
