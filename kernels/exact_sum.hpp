// Order-independent summation: each term is rounded once to a fixed-point grid of 2^-64
// and added as a 128-bit integer. Integer addition is associative, so the total has the
// same bits for any thread count, rank count or summation order (docs/physics.md section 7).
// Range: |term| < 2^40 (about 1e12); a larger or non-finite term poisons the sum to NaN
// so that the caller's NaN checks stop the run instead of continuing with garbage.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace hardrod {

// GCC/Clang 128-bit integers; __extension__ keeps -Wpedantic quiet about them.
__extension__ typedef __int128 Int128;
__extension__ typedef unsigned __int128 UInt128;

class ExactSum {
 public:
  static constexpr int kFractionBits = 64;
  static constexpr double kMaxTerm = 1099511627776.0;  // 2^40

  void add(double term) {
    if (!(std::fabs(term) < kMaxTerm)) {  // also catches NaN
      poisoned_ = true;
      return;
    }
    acc_ += to_grid(term);
  }
  // The term on the grid: term 2^64 truncated toward zero, as
  // static_cast<Int128>(std::ldexp(term, 64)) gives, without the two library calls (the
  // thermostat adds two terms per body). |term| < 2^40, so the result fits in 105 bits.
  static Int128 to_grid(double term) {
    std::uint64_t bits;
    std::memcpy(&bits, &term, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    const std::uint64_t mantissa =
        (bits & ((std::uint64_t{1} << 52) - 1)) | (biased ? std::uint64_t{1} << 52 : 0);
    // term = mantissa 2^(e - 64) with e below, so term 2^64 = mantissa 2^e.
    const int e = (biased ? biased : 1) - 1075 + kFractionBits;
    UInt128 magnitude = 0;
    if (e >= 0)
      magnitude = static_cast<UInt128>(mantissa) << e;
    else if (e > -64)
      magnitude = mantissa >> -e;  // truncation toward zero
    const auto m = static_cast<Int128>(magnitude);
    return (bits >> 63) ? -m : m;
  }
  ExactSum &operator+=(const ExactSum &o) {
    acc_ += o.acc_;
    poisoned_ = poisoned_ || o.poisoned_;
    return *this;
  }
  double value() const {
    if (poisoned_) return std::numeric_limits<double>::quiet_NaN();
    // Split into high and low 64-bit halves so the conversion to double rounds once
    // deterministically (the sum of two exactly representable parts).
    const bool negative = acc_ < 0;
    const UInt128 mag = negative ? static_cast<UInt128>(-acc_) : static_cast<UInt128>(acc_);
    const auto hi = static_cast<std::uint64_t>(mag >> 64);
    const auto lo = static_cast<std::uint64_t>(mag);
    const double v = static_cast<double>(hi) + std::ldexp(static_cast<double>(lo), -64);
    return negative ? -v : v;
  }
  bool poisoned() const { return poisoned_; }
  // Raw state, for reductions across ranks (two 64-bit words plus the flag).
  Int128 raw() const { return acc_; }
  static ExactSum from_raw(Int128 raw, bool poisoned) {
    ExactSum s;
    s.acc_ = raw;
    s.poisoned_ = poisoned;
    return s;
  }

 private:
  Int128 acc_ = 0;
  bool poisoned_ = false;
};

}  // namespace hardrod
