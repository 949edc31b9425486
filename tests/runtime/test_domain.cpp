// The domain's cuts (uniform and moved by the load balancer) and the balancer's arithmetic.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "runtime/balance.hpp"
#include "runtime/domain.hpp"

namespace hardrod {
namespace {

Box box_of(double x, double y, double z) {
  Box b;
  b.length = {x, y, z};
  return b;
}

// Every point is owned by the rank whose [lower, upper) holds it, for any cuts.
void expect_owner_holds_point(const Box &box, std::array<int, 3> grid, const Cuts &cuts) {
  const Domain d(box, grid, 0, 1.0, 2.0, cuts);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 2.0);  // also outside the box: folded
  for (int k = 0; k < 20000; ++k) {
    const Vec3 p{u(rng) * box.length.x, u(rng) * box.length.y, u(rng) * box.length.z};
    const Vec3 f = box.wrap(p);
    const double x[3] = {f.x, f.y, f.z};
    const int r = d.owner_of(p);
    ASSERT_GE(r, 0);
    ASSERT_LT(r, d.ranks());
    const auto lo = d.lower(r), hi = d.upper(r);
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(lo[a], x[a]);
      EXPECT_LT(x[a], hi[a]);
    }
  }
  // The cut itself belongs to the slab above it.
  for (int a = 0; a < 3; ++a)
    for (int k = 1; k < grid[a]; ++k) {
      double x[3] = {0.5 * cuts[0][1], 0.5 * cuts[1][1], 0.5 * cuts[2][1]};
      x[a] = cuts[a][static_cast<std::size_t>(k)];
      const int r = d.owner_of({x[0], x[1], x[2]});
      EXPECT_EQ(d.lower(r)[a], x[a]);
    }
}

TEST(Domain, UniformCutsSplitEvenly) {
  const Box box = box_of(30.0, 20.0, 10.0);
  const Cuts c = Domain::uniform_cuts(box, {3, 2, 1});
  ASSERT_EQ(c[0].size(), 4u);
  EXPECT_DOUBLE_EQ(c[0][1], 10.0);
  EXPECT_DOUBLE_EQ(c[0][3], 30.0);
  EXPECT_DOUBLE_EQ(c[1][1], 10.0);
  ASSERT_EQ(c[2].size(), 2u);
  expect_owner_holds_point(box, {3, 2, 1}, c);
}

TEST(Domain, MovedCutsOwnAndPartnerConsistently) {
  const Box box = box_of(40.0, 40.0, 40.0);
  const std::array<int, 3> grid{4, 2, 1};
  const Cuts cuts{{{0.0, 6.0, 17.5, 31.0, 40.0}, {0.0, 25.0, 40.0}, {0.0, 40.0}}};
  expect_owner_holds_point(box, grid, cuts);
  // Partners are symmetric and found from the moved cuts: with reach 3, slab 0 (width 6)
  // and slab 2 are 11.5 apart, not partners; slab 0 and slab 3 touch through the period.
  std::vector<Domain> all;
  for (int r = 0; r < 8; ++r) all.emplace_back(box, grid, r, 1.0, 3.0, cuts);
  for (int r = 0; r < 8; ++r)
    for (int q : all[static_cast<std::size_t>(r)].partners()) {
      const auto &back = all[static_cast<std::size_t>(q)].partners();
      EXPECT_NE(std::find(back.begin(), back.end(), r), back.end()) << r << " " << q;
    }
  const auto &p0 = all[0].partners();                       // rank 0: x slab 0, y slab 0
  EXPECT_EQ(std::find(p0.begin(), p0.end(), 2), p0.end());  // x slab 2
  EXPECT_NE(std::find(p0.begin(), p0.end(), 3), p0.end());  // x slab 3, through the period
  EXPECT_NE(std::find(p0.begin(), p0.end(), 1), p0.end());
}

// reached_partners gives the holders of testing every partner with reaches(): on even and
// moved cuts, grids with one, two and many slabs, segments anywhere (also just at the reach).
TEST(Domain, ReachedPartnersAreThoseEveryPartnerTestAccepts) {
  const Box box = box_of(40.0, 36.0, 30.0);
  struct Case {
    std::array<int, 3> grid;
    Cuts cuts;
  };
  const std::vector<Case> cases{
      {{4, 2, 1}, {{{0.0, 6.0, 17.5, 31.0, 40.0}, {0.0, 25.0, 36.0}, {0.0, 30.0}}}},
      {{4, 4, 4}, {}},
      {{2, 3, 5}, {}},
      {{8, 1, 2}, {}}};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.5, 1.5), n(-1.0, 1.0);
  long long accepted = 0, tested = 0;
  for (const Case &c : cases) {
    const Box &b = box;
    const int ranks = c.grid[0] * c.grid[1] * c.grid[2];
    for (int r = 0; r < ranks; r += 3) {
      const Domain d(b, c.grid, r, 3.9, 7.0, c.cuts);
      const auto lo = d.lower(r), hi = d.upper(r);
      for (int k = 0; k < 4000; ++k) {
        Vec3 e{n(rng), n(rng), n(rng)};
        e = (1.0 / std::sqrt(dot(e, e))) * e;
        // Centres in and around the subdomain; every fourth one at the reach from a face.
        Vec3 x{lo[0] + u(rng) * (hi[0] - lo[0]), lo[1] + u(rng) * (hi[1] - lo[1]),
               lo[2] + u(rng) * (hi[2] - lo[2])};
        if (k % 4 == 0) x.x = hi[0] + d.shadow_reach() + std::fabs(e.x) * 2.5;
        std::vector<int> fast;
        d.reached_partners(x, e, 2.5, fast);
        std::vector<int> every;
        for (int q : d.partners())
          if (d.reaches(x, e, 2.5, q)) every.push_back(q);
        ASSERT_EQ(fast, every) << "rank " << r << " of " << ranks;
        accepted += static_cast<long long>(every.size());
        tested += static_cast<long long>(d.partners().size());
      }
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_LT(accepted, tested);  // some partners are reached, not all
}

TEST(Domain, RejectsCutsThatDoNotRise) {
  const Box box = box_of(10.0, 10.0, 10.0);
  Cuts c = Domain::uniform_cuts(box, {2, 1, 1});
  c[0][1] = 0.0;
  EXPECT_THROW(Domain(box, {2, 1, 1}, 0, 1.0, 2.0, c), std::invalid_argument);
  c[0] = {0.0, 5.0, 9.0};  // does not end at the side
  EXPECT_THROW(Domain(box, {2, 1, 1}, 0, 1.0, 2.0, c), std::invalid_argument);
  c[0] = {0.0, 5.0};  // one slab short
  EXPECT_THROW(Domain(box, {2, 1, 1}, 0, 1.0, 2.0, c), std::invalid_argument);
}

// The load of each new slab when the old slabs' loads are spread evenly over them.
std::vector<double> shares(const std::vector<double> &old_cuts, const std::vector<double> &loads,
                           const std::vector<double> &cuts) {
  std::vector<double> out(loads.size(), 0.0);
  for (std::size_t s = 0; s < loads.size(); ++s)
    for (std::size_t o = 0; o < loads.size(); ++o) {
      const double lo = std::max(cuts[s], old_cuts[o]), hi = std::min(cuts[s + 1], old_cuts[o + 1]);
      if (hi > lo) out[s] += loads[o] * (hi - lo) / (old_cuts[o + 1] - old_cuts[o]);
    }
  return out;
}

TEST(Balance, EqualLoadsKeepTheCuts) {
  const std::vector<double> cuts{0.0, 10.0, 20.0, 30.0};
  EXPECT_EQ(balanced_cuts(cuts, {2.0, 2.0, 2.0}, 1.0), cuts);
}

TEST(Balance, CutsGiveEverySlabTheSameLoad) {
  const std::vector<double> cuts{0.0, 10.0, 20.0, 30.0, 40.0};
  const std::vector<double> loads{5.0, 1.0, 1.0, 1.0};
  const auto next = balanced_cuts(cuts, loads, 0.1);
  ASSERT_EQ(next.size(), cuts.size());
  EXPECT_EQ(next.front(), 0.0);
  EXPECT_EQ(next.back(), 40.0);
  for (double s : shares(cuts, loads, next)) EXPECT_NEAR(s, 2.0, 1e-12);
  EXPECT_NEAR(next[1], 4.0, 1e-12);  // the busy slab shrinks to 2 / 5 of its width
}

TEST(Balance, LimitsHoldAndTheStepIsTheLargestThatKeepsThem) {
  const std::vector<double> cuts{0.0, 10.0, 20.0};
  // Unlimited target: 1.0 (load 100 : 1 -> the first slab ~1.05 wide).
  const auto free = balanced_cuts(cuts, {100.0, 1.0}, 0.1);
  EXPECT_NEAR(free[1], 10.0 * 50.5 / 100.0, 1e-12);
  // No slab thinner than 6: the cut stops at 6, a step of 4 / 4.95 of the way.
  const auto wide = balanced_cuts(cuts, {100.0, 1.0}, 6.0);
  EXPECT_NEAR(wide[1], 6.0, 1e-12);
}

// A slab that an earlier step stopped at the limit (its width rounded a little below it) still
// moves where the loads ask for it to grow; one that would shrink further stays.
TEST(Balance, ASlabAtTheLimitMovesAgain) {
  const std::vector<double> cuts{0.0, std::nextafter(6.0, 0.0), 20.0};
  const auto grown = balanced_cuts(cuts, {1.0, 100.0}, 6.0);
  EXPECT_GT(grown[1], 6.0);
  const auto kept = balanced_cuts(cuts, {100.0, 1.0}, 6.0);
  EXPECT_EQ(kept, cuts);
}

TEST(Balance, BadLoadsOrCutsChangeNothing) {
  const std::vector<double> cuts{0.0, 10.0, 20.0};
  EXPECT_EQ(balanced_cuts(cuts, {NAN, 1.0}, 1.0), cuts);
  EXPECT_EQ(balanced_cuts(cuts, {-1.0, 1.0}, 1.0), cuts);
  EXPECT_EQ(balanced_cuts(cuts, {0.0, 0.0}, 1.0), cuts);
  EXPECT_EQ(balanced_cuts(cuts, {1.0, 2.0, 3.0}, 1.0), cuts);  // sizes differ
  EXPECT_EQ(balanced_cuts(cuts, {3.0, 1.0}, 11.0), cuts);      // already thinner than allowed
  EXPECT_EQ(balanced_cuts({0.0, 10.0}, {1.0}, 1.0), (std::vector<double>{0.0, 10.0}));
}

TEST(Balance, ModeNames) {
  for (BalanceMode m : {BalanceMode::kOff, BalanceMode::kBodies, BalanceMode::kTime})
    EXPECT_EQ(parse_balance_mode(balance_mode_name(m)), m);
  try {
    parse_balance_mode("fast");
    FAIL() << "no error";
  } catch (const std::invalid_argument &e) {
    EXPECT_NE(std::string(e.what()).find("'fast'"), std::string::npos);
  }
}

}  // namespace
}  // namespace hardrod
