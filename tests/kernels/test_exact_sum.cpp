#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "kernels/exact_sum.hpp"

namespace hardrod {
namespace {

TEST(ExactSum, IndependentOfOrder) {
  std::mt19937_64 rng(9);
  std::lognormal_distribution<double> mag(0.0, 4.0);
  std::vector<double> terms(20000);
  for (auto &t : terms) t = (rng() & 1 ? 1 : -1) * mag(rng);
  ExactSum a;
  for (double t : terms) a.add(t);
  std::shuffle(terms.begin(), terms.end(), rng);
  ExactSum b, c;  // shuffled, and split in two halves merged
  for (std::size_t k = 0; k < terms.size(); ++k) (k % 3 ? b : c).add(terms[k]);
  b += c;
  EXPECT_EQ(a.raw(), b.raw());
  // And it is accurate: compare with a long double sum.
  long double ref = 0;
  for (double t : terms) ref += t;
  EXPECT_NEAR(a.value(), static_cast<double>(ref),
              1e-9 * std::fabs(static_cast<double>(ref)) + 1e-9);
  // Naive double summation does depend on the order (otherwise this test proves nothing).
  double s1 = 0, s2 = 0;
  for (double t : terms) s1 += t;
  std::reverse(terms.begin(), terms.end());
  for (double t : terms) s2 += t;
  EXPECT_NE(s1, s2);
}

TEST(ExactSum, PoisonedByNaNAndHugeTerms) {
  ExactSum s;
  s.add(1.0);
  s.add(std::nan(""));
  EXPECT_TRUE(std::isnan(s.value()));
  ExactSum h;
  h.add(1e300);
  EXPECT_TRUE(h.poisoned());
}

TEST(ExactSum, NegativeAndSmall) {
  ExactSum s;
  s.add(-2.5);
  s.add(1e-12);
  EXPECT_DOUBLE_EQ(s.value(), -2.5 + 1e-12);
}

// The grid conversion without library calls gives the bits of the cast it replaces, for
// terms of every magnitude the range allows, both signs, subnormals and exact integers.
TEST(ExactSum, GridConversionEqualsTheCast) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> mant(1.0, 2.0);
  std::uniform_int_distribution<int> expo(-1074, 39);
  std::vector<double> terms{0.0,
                            -0.0,
                            1.0,
                            -1.0,
                            0.5,
                            1e-300,
                            -1e-300,
                            5e-324,
                            -5e-324,
                            std::ldexp(1.0, -64),
                            std::ldexp(1.0, -65),
                            std::ldexp(3.0, -66),
                            -std::ldexp(3.0, -66),
                            std::ldexp(1.0, 39) * 1.9999999,
                            123456789.0,
                            -0.1,
                            0.1,
                            std::nextafter(1.0, 2.0),
                            -std::nextafter(1.0, 0.0)};
  for (int k = 0; k < 200000; ++k) {
    const double t = std::ldexp(mant(rng), expo(rng));
    terms.push_back(k % 2 ? t : -t);
  }
  for (const double t : terms) {
    const Int128 cast = static_cast<Int128>(std::ldexp(t, ExactSum::kFractionBits));
    ASSERT_TRUE(ExactSum::to_grid(t) == cast) << t;
  }
}

}  // namespace
}  // namespace hardrod
