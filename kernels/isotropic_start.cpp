// Random placement and QuickCompress-style Monte Carlo compression (isotropic_start.hpp).
// Bodies are re-sorted by cell at every cell-list rebuild so that a cell's bodies are
// contiguous; ids travel with them and the result is sorted back by id at the end.
#include "kernels/isotropic_start.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "kernels/cell_list.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/random.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

constexpr double kAcceptLow = 0.2;   // move sizes shrink below this acceptance ...
constexpr double kAcceptHigh = 0.4;  // ... and grow above it
constexpr double kInitialMove = 0.25;
constexpr double kMaxStep = 0.5;   // largest translation per axis, in D
constexpr double kMaxTilt = 1.0;   // largest axis perturbation: |e + tilt v| > 0 for |v| < 1
constexpr double kMinMove = 1e-9;  // floor for move sizes, so a stuck run never goes denormal
constexpr double kSkin = 0.5;      // neighbour list margin beyond L + D, in D ...
constexpr double kListSweeps = 6;  // ... plus room for this many sweeps of largest steps
constexpr int kFinalPasses = 10;   // passes over the overlapping bodies per sweep at the target
constexpr double kSqrt3 = std::numbers::sqrt3;

std::string text(double x) {
  std::string s = std::to_string(x);
  s.erase(s.find_last_not_of('0') + 1);
  if (s.back() == '.') s.pop_back();
  return s;
}

std::string describe(const Box &box) {
  return text(box.length.x) + " x " + text(box.length.y) + " x " + text(box.length.z);
}

Box scaled(const Box &box, double s) {
  Box out = box;
  out.length = s * box.length;
  return out;
}

// Sequential draws from one counter-based stream keyed by the seed.
class Stream {
 public:
  explicit Stream(std::uint64_t seed) : random_(seed, RandomPurpose::kPlacement, 0) {}

  double uniform() { return random_.uniform(); }                // (0, 1)
  double symmetric() { return 2.0 * random_.uniform() - 1.0; }  // (-1, 1)
  std::size_t index(std::size_t n) {                            // [0, n)
    return std::min(n - 1, static_cast<std::size_t>(uniform() * static_cast<double>(n)));
  }
  // Uniform on the sphere: cos(theta) uniform in (-1, 1), phi uniform.
  Vec3 unit_vector() {
    const double z = symmetric();
    const double phi = 2.0 * std::numbers::pi * uniform();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }
  // Uniform in the open unit ball (rejection from the cube): an isotropic perturbation.
  Vec3 in_ball() {
    for (;;) {
      Vec3 v;
      v.x = symmetric();
      v.y = symmetric();
      v.z = symmetric();
      if (norm2(v) < 1.0) return v;
    }
  }

 private:
  CounterRandom random_;
};

// Move size toward kAcceptLow..kAcceptHigh acceptance, within [kMinMove, cap].
void adapt(double &size, long long accepted, long long tried, double cap) {
  if (tried == 0) return;
  const double rate = static_cast<double>(accepted) / static_cast<double>(tried);
  if (rate > kAcceptHigh) size = std::min(cap, 1.1 * size);
  if (rate < kAcceptLow) size = std::max(kMinMove, 0.9 * size);
}

class Compressor {
 public:
  Compressor(std::size_t n, const Shape &shape, const Box &target, double start_scale,
             std::uint64_t seed, const CompressionOptions &options)
      : shape_(shape),
        half_(shape.half_length()),
        diameter2_(shape.diameter * shape.diameter),
        range2_(shape.interaction_range() * shape.interaction_range()),
        clear2_(std::pow((1.0 + 1e-6) * (shape.diameter + shape.half_length()), 2)),
        target_(target),
        scale_(start_scale),
        box_(scaled(target, start_scale)),
        inverse_(box_.inverse_length()),
        bound_(static_cast<long long>(options.overlap_fraction * static_cast<double>(n))),
        // A fresh neighbour list stays valid for a shrink by skin / (L + D + skin).
        max_shrink_(
            std::min(options.max_shrink, 0.5 * skin() / (shape.interaction_range() + skin()))),
        shrink_(max_shrink_),
        stream_(seed) {
    p_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      p_.id[i] = static_cast<std::int64_t>(i);
      Vec3 x;
      x.x = box_.length.x * stream_.uniform();
      x.y = box_.length.y * stream_.uniform();
      x.z = box_.length.z * stream_.uniform();
      p_.set_position(i, box_.wrap(x));
      p_.set_axis(i, stream_.unit_vector());
    }
    visit_.resize(n);
    for (std::size_t i = 0; i < n; ++i) visit_[i] = static_cast<std::uint32_t>(i);
    overlaps_.assign(n, 0);
    rebuild();
    pairs_ = count_all(std::numeric_limits<long long>::max());
  }

  bool finished() const { return scale_ == 1.0 && pairs_ == 0; }
  // A shrink is tried only with room for new overlaps: at most half the bound left.
  bool may_shrink() const { return scale_ > 1.0 && pairs_ <= bound_ / 2; }
  double scale() const { return scale_; }
  long long overlapping_pairs() const { return pairs_; }

  // Every body once, in a random order; move sizes then adapt to this sweep's acceptance.
  // At the target box, up to kFinalPasses passes over the bodies that still overlap follow.
  void sweep() {
    tried_[0] = tried_[1] = accepted_[0] = accepted_[1] = 0;
    pass(false);
    adapt(step_, accepted_[0], tried_[0], kMaxStep);
    adapt(tilt_, accepted_[1], tried_[1], kMaxTilt);
    for (int k = 0; k < kFinalPasses && scale_ == 1.0 && pairs_ > 0; ++k) pass(true);
  }

  // Shrinks the box toward the target by up to shrink_ of a side, centres scaled affinely.
  // Kept iff at most bound_ pairs overlap afterwards; the step grows after a kept shrink and
  // halves after an undone one.
  bool try_shrink() {
    const double next = std::max(1.0, scale_ * (1.0 - shrink_));
    const double ratio = next / scale_;
    if (!list_valid(ratio, 0.0)) rebuild();  // a fresh list allows any shrink up to max_shrink_
    const Box old_box = box_;
    const std::vector<double> x = p_.x, y = p_.y, z = p_.z;
    const std::vector<int> saved_overlaps = overlaps_;
    box_ = scaled(target_, next);  // exactly the target when next == 1
    inverse_ = box_.inverse_length();
    const Vec3 r{box_.length.x / old_box.length.x, box_.length.y / old_box.length.y,
                 box_.length.z / old_box.length.z};
    for (std::size_t i = 0; i < p_.size(); ++i)
      p_.set_position(i, box_.wrap({x[i] * r.x, y[i] * r.y, z[i] * r.z}));
    const long long pairs = count_all(bound_);
    if (pairs > bound_) {
      box_ = old_box;
      inverse_ = box_.inverse_length();
      p_.x = x;
      p_.y = y;
      p_.z = z;
      overlaps_ = saved_overlaps;
      shrink_ *= 0.5;
      return false;
    }
    pairs_ = pairs;
    scale_ = next;
    max_drift_ *= ratio;
    shrink_ = std::min(max_shrink_, 1.5 * shrink_);
    return true;
  }

  // The bodies, sorted back by id.
  Particles release() {
    std::vector<std::uint32_t> by_id(p_.size());
    for (std::size_t k = 0; k < p_.size(); ++k)
      by_id[static_cast<std::size_t>(p_.id[k])] = static_cast<std::uint32_t>(k);
    p_.permute(by_id);
    return std::move(p_);
  }

 private:
  struct Scan {
    int count = 0;       // overlapping partners
    double depth = 0.0;  // sum of D - axis distance over them
  };

  double skin() const { return kSkin * shape_.diameter; }

  // One move of every body, or of every body with overlaps, in a random order.
  void pass(bool only_overlapping) {
    if (!list_valid(1.0, kSqrt3 * step_)) rebuild();  // (re-sorts the bodies)
    std::vector<std::uint32_t> &bodies = only_overlapping ? overlapping_ : visit_;
    if (only_overlapping) {
      bodies.clear();
      for (std::size_t i = 0; i < overlaps_.size(); ++i)
        if (overlaps_[i] > 0) bodies.push_back(static_cast<std::uint32_t>(i));
    }
    for (std::size_t k = bodies.size(); k > 1; --k)
      std::swap(bodies[k - 1], bodies[stream_.index(k)]);
    for (const std::uint32_t i : bodies) attempt(i);
  }

  // A translation uniform in a cube, or for rods with probability 1/2 a rotation of the axis
  // by an isotropic random vector. A body without overlaps may not gain any (rejected at the
  // first); a body with overlaps may move iff its overlap depth does not grow.
  void attempt(std::uint32_t i) {
    const Vec3 x_old = p_.position(i);
    const Vec3 e_old = p_.axis(i);
    Vec3 x_new = x_old;
    Vec3 e_new = e_old;
    const bool rotate = !shape_.is_sphere() && stream_.uniform() < 0.5;
    if (rotate) {
      const Vec3 e = e_old + tilt_ * stream_.in_ball();
      e_new = (1.0 / norm(e)) * e;
    } else {
      Vec3 d;
      d.x = stream_.symmetric();
      d.y = stream_.symmetric();
      d.z = stream_.symmetric();
      x_new = box_.wrap(x_old + step_ * d);  // tested as stored
    }
    ++tried_[rotate];
    const int before = overlaps_[i];
    gained_.clear();
    if (before == 0) {
      if (scan(i, x_new, e_new, 0.0, gained_).count > 0) return;
    } else {
      lost_.clear();
      const Scan now = scan(i, x_old, e_old, std::numeric_limits<double>::infinity(), lost_);
      const Scan next = scan(i, x_new, e_new, now.depth, gained_);
      if (next.depth > now.depth) return;
      for (const std::uint32_t j : lost_) --overlaps_[j];
      for (const std::uint32_t j : gained_) ++overlaps_[j];
      overlaps_[i] = next.count;
      pairs_ += next.count - before;
    }
    ++accepted_[rotate];
    if (!rotate) {
      const Vec3 drift = box_.minimum_image(x_new - (scale_ / build_scale_) * built_[i], inverse_);
      max_drift_ = std::max(max_drift_, norm(drift));
    }
    p_.set_position(i, x_new);
    p_.set_axis(i, e_new);
  }

  // Whether the neighbour list still holds every pair that can overlap after the box side
  // is multiplied by `ratio` and every body moves by up to `extra`: pairs outside it were
  // at least range_ apart at the build; since then the box shrank and each centre drifted
  // (from its build position, scaled) by at most max_drift_.
  bool list_valid(double ratio, double extra) const {
    const double shrunk = ratio * scale_ / build_scale_;
    return 2.0 * (ratio * max_drift_ + extra) <
           shrunk * range_ - shape_.interaction_range() - 1e-9 * range_;
  }

  // Sorts the bodies by cell (a cell's bodies are then contiguous in memory) and lists, for
  // every body, the bodies whose centres are closer than L + D + skin + room for
  // kListSweeps sweeps at the current step, nearest axis first: an overlap, if any, is
  // then usually found (and the move rejected) after a few pairs.
  void rebuild() {
    range_ = shape_.interaction_range() + skin() + kListSweeps * kSqrt3 * step_;
    build_cell_list(cells_, p_, p_.size(), box_, range_);
    p_.permute(cells_.order);
    std::vector<int> sorted(overlaps_.size());
    for (std::size_t k = 0; k < sorted.size(); ++k) sorted[k] = overlaps_[cells_.order[k]];
    overlaps_ = std::move(sorted);
    neighbour_start_.assign(p_.size() + 1, 0);
    neighbours_.clear();
    std::vector<int> around;
    for (int cz = 0; cz < cells_.extent[2]; ++cz)
      for (int cy = 0; cy < cells_.extent[1]; ++cy)
        for (int cx = 0; cx < cells_.extent[0]; ++cx) {
          around.clear();
          for (const auto &o : cells_.stencil) around.push_back(cells_.neighbour(cx, cy, cz, o));
          const int c = cells_.cell_index(cx, cy, cz);
          for (std::uint32_t i = cells_.cell_start[c]; i < cells_.cell_start[c + 1]; ++i) {
            const Vec3 x = p_.position(i);
            const Vec3 e = p_.axis(i);
            near_.clear();
            for (const int a : around)
              for (std::uint32_t j = cells_.cell_start[a]; j < cells_.cell_start[a + 1]; ++j) {
                const Vec3 r = box_.minimum_image(p_.position(j) - x, inverse_);
                if (j != i && norm2(r) < range_ * range_)
                  near_.push_back(
                      {segment_closest_inline(r, e, half_, p_.axis(j), half_).dist2, j});
              }
            std::sort(near_.begin(), near_.end());
            for (const auto &[d2, j] : near_) neighbours_.push_back(j);
            neighbour_start_[i + 1] = neighbours_.size();
          }
        }
    built_.resize(p_.size());
    for (std::size_t i = 0; i < p_.size(); ++i) built_[i] = p_.position(i);
    build_scale_ = scale_;
    max_drift_ = 0.0;
  }

  // Calls visit(j) for every listed neighbour j of body i until it returns true.
  template <class Visit>
  void for_each_neighbour(std::size_t i, Visit visit) const {
    for (std::size_t k = neighbour_start_[i]; k < neighbour_start_[i + 1]; ++k)
      if (visit(neighbours_[k])) return;
  }

  // Whether body i, placed at (x, e), overlaps body j, and then their squared axis
  // distance. Always evaluated with the lower id first (the negated minimum image is exactly
  // the other order's), so a pair gets the same bits whichever body moves and in the final
  // check.
  bool overlap(std::size_t i, const Vec3 &x, const Vec3 &e, std::size_t j, double &d2) const {
    const Vec3 r = box_.minimum_image(p_.position(j) - x, inverse_);
    if (norm2(r) >= range2_) return false;
    const Vec3 f = p_.axis(j);
    // Cheap rejection: every point of an axis is within h of its centre, so when either
    // centre is clearly farther than D + h from the other axis the pair cannot overlap.
    if (norm2(r - std::clamp(dot(r, e), -half_, half_) * e) >= clear2_ ||
        norm2(r - std::clamp(dot(r, f), -half_, half_) * f) >= clear2_)
      return false;
    d2 = p_.id[i] < p_.id[j] ? segment_closest_inline(r, e, half_, f, half_).dist2
                             : segment_closest_inline(-r, f, half_, e, half_).dist2;
    return d2 < diameter2_;
  }

  // Overlaps of body i placed at (x, e), partners appended to `found`; stops once the depth
  // exceeds `limit` (limit 0: at the first overlap).
  Scan scan(std::size_t i, const Vec3 &x, const Vec3 &e, double limit,
            std::vector<std::uint32_t> &found) const {
    Scan out;
    for_each_neighbour(i, [&](std::size_t j) {
      double d2 = 0.0;
      if (!overlap(i, x, e, j, d2)) return false;
      ++out.count;
      out.depth += shape_.diameter - std::sqrt(d2);
      found.push_back(static_cast<std::uint32_t>(j));
      return out.depth > limit;
    });
    return out;
  }

  // Recounts every body's overlaps and returns the overlapping pairs; stops (the counts then
  // partial) once they exceed `limit`.
  long long count_all(long long limit) {
    std::fill(overlaps_.begin(), overlaps_.end(), 0);
    long long pairs = 0;
    for (std::size_t i = 0; i < p_.size() && pairs <= limit; ++i) {
      const Vec3 x = p_.position(i);
      const Vec3 e = p_.axis(i);
      for_each_neighbour(i, [&](std::size_t j) {
        double d2 = 0.0;
        if (j > i && overlap(i, x, e, j, d2)) {
          ++overlaps_[i];
          ++overlaps_[j];
          ++pairs;
        }
        return pairs > limit;
      });
    }
    return pairs;
  }

  Shape shape_;
  double half_, diameter2_, range2_;
  double clear2_;  // (D + h)^2 with a relative margin of 1e-6 for the cheap rejection
  Box target_;
  double scale_;  // box_ side / target side
  Box box_;
  Vec3 inverse_;
  long long bound_;  // overlapping pairs a shrink may leave
  double max_shrink_, shrink_;
  Stream stream_;
  double step_ = kInitialMove, tilt_ = kInitialMove;
  long long tried_[2] = {0, 0}, accepted_[2] = {0, 0};  // this sweep: translations, rotations

  Particles p_;
  std::vector<int> overlaps_;  // per body
  long long pairs_ = 0;        // overlapping pairs: sum of overlaps_ / 2
  CellList cells_;
  // Neighbour (Verlet) list: the bodies within range_ of body i at the last build are
  // neighbours_[neighbour_start_[i] .. neighbour_start_[i + 1]).
  std::vector<std::size_t> neighbour_start_;
  std::vector<std::uint32_t> neighbours_;
  double range_ = 0.0;
  std::vector<Vec3> built_;  // positions at the build
  double build_scale_ = 1.0;
  double max_drift_ = 0.0;  // bound on |position - scaled build position| over the bodies
  std::vector<std::uint32_t> visit_, overlapping_, gained_, lost_;
  std::vector<std::pair<double, std::uint32_t>> near_;
};

struct PairCheck {
  long long overlaps = 0;
  double min_gap = std::numeric_limits<double>::infinity();  // over pairs closer than L + 2D
};

// Every pair whose centres are closer than L + 2D, through a fresh cell list, lower id
// first (bodies are in id order), as Compressor::overlap evaluates it.
PairCheck check_pairs(const Particles &p, const Shape &shape, const Box &box) {
  const double reach = shape.interaction_range() + shape.diameter;
  const double h = shape.half_length();
  CellList cells;
  build_cell_list(cells, p, p.size(), box, reach);
  std::vector<std::array<int, 3>> cell_of(p.size());
  for (int cz = 0; cz < cells.extent[2]; ++cz)
    for (int cy = 0; cy < cells.extent[1]; ++cy)
      for (int cx = 0; cx < cells.extent[0]; ++cx) {
        const int c = cells.cell_index(cx, cy, cz);
        for (std::uint32_t k = cells.cell_start[c]; k < cells.cell_start[c + 1]; ++k)
          cell_of[cells.order[k]] = {cx, cy, cz};
      }
  const Vec3 inverse = box.inverse_length();
  PairCheck out;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (const auto &o : cells.stencil) {
      const int c = cells.neighbour(cell_of[i][0], cell_of[i][1], cell_of[i][2], o);
      for (std::uint32_t k = cells.cell_start[c]; k < cells.cell_start[c + 1]; ++k) {
        const std::size_t j = cells.order[k];
        if (j <= i) continue;
        const Vec3 r = box.minimum_image(p.position(j) - p.position(i), inverse);
        if (norm2(r) >= reach * reach) continue;
        const double d2 = segment_closest_inline(r, p.axis(i), h, p.axis(j), h).dist2;
        if (d2 < shape.diameter * shape.diameter) ++out.overlaps;
        out.min_gap = std::min(out.min_gap, std::sqrt(d2) - shape.diameter);
      }
    }
  return out;
}

void validate(long long n, const Shape &shape, const Box &target,
              const CompressionOptions &options) {
  const auto fail = [](const std::string &what) {
    throw std::invalid_argument("make_isotropic: " + what);
  };
  if (n < 1) fail("n = " + std::to_string(n) + " must be >= 1");
  if (!(shape.diameter > 0.0 && std::isfinite(shape.diameter)) ||
      !(shape.length >= 0.0 && std::isfinite(shape.length)))
    fail("the shape needs D > 0 and L >= 0, finite");
  const double range = 2.0 * shape.interaction_range();
  for (const double s : {target.length.x, target.length.y, target.length.z})
    if (!(std::isfinite(s) && s > range))
      fail("box " + describe(target) + ": every side must exceed 2 (L + D) = " + text(range) +
           " (the minimum image must be unique)");
  const double close = shape.close_packing_density() * shape.volume();
  if (!(options.start_packing_fraction > 0.0 && options.start_packing_fraction < close))
    fail("start_packing_fraction = " + text(options.start_packing_fraction) + " must be in (0, " +
         text(close) + ")");
  if (options.max_sweeps < 0) fail("max_sweeps must be >= 0");
  if (!(options.max_seconds >= 0.0)) fail("max_seconds must be >= 0");
  if (!(options.overlap_fraction >= 0.0 && std::isfinite(options.overlap_fraction)))
    fail("overlap_fraction must be >= 0 and finite");
  if (!(options.max_shrink > 0.0 && options.max_shrink < 1.0)) fail("max_shrink must be in (0, 1)");
}

}  // namespace

Particles make_isotropic(long long n, const Shape &shape, const Box &target, std::uint64_t seed,
                         const CompressionOptions &options, CompressionReport *report) {
  validate(n, shape, target, options);
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&start] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const double fraction = static_cast<double>(n) * shape.volume() / target.volume();
  const double close = shape.close_packing_density() * shape.volume();
  const std::string goal = "packing fraction " + text(fraction) + " (" + std::to_string(n) +
                           " bodies, L/D = " + text(shape.length / shape.diameter) + ", box " +
                           describe(target) + ")";
  if (fraction >= close)
    throw std::runtime_error("make_isotropic: " + goal + " cannot be reached: close packing is " +
                             text(close));

  const double start_scale = std::max(1.0, std::cbrt(fraction / options.start_packing_fraction));
  Compressor run(static_cast<std::size_t>(n), shape, target, start_scale, seed, options);
  CompressionReport out;
  double next_progress = options.progress_seconds;
  while (!run.finished()) {
    const bool out_of_sweeps = out.sweeps >= options.max_sweeps;
    if (out_of_sweeps || (options.max_seconds > 0.0 && elapsed() > options.max_seconds)) {
      if (options.progress) options.progress(out.sweeps, run.scale());  // where it stopped
      out.seconds = elapsed();
      out.box_scale = run.scale();
      out.overlapping_pairs = run.overlapping_pairs();
      if (report) *report = out;
      throw std::runtime_error(
          "make_isotropic: " + goal + " not reached " +
          (out_of_sweeps ? "in max_sweeps = " + std::to_string(options.max_sweeps) + " sweeps"
                         : "in max_seconds = " + text(options.max_seconds) + " s") +
          ": the box side is still " + text(run.scale()) + " times the target's, with " +
          std::to_string(run.overlapping_pairs()) +
          " overlapping pairs; lower the density or allow more sweeps");
    }
    if (options.stop && options.stop())
      throw CompressionStopped("make_isotropic: stopped on request after " +
                               std::to_string(out.sweeps) + " sweeps");
    if (options.progress && elapsed() >= next_progress) {
      options.progress(out.sweeps, run.scale());
      next_progress += options.progress_seconds;
    }
    run.sweep();
    ++out.sweeps;
    if (run.may_shrink() && run.try_shrink()) ++out.compressions;
  }

  Particles p = run.release();
  const PairCheck check = check_pairs(p, shape, target);
  if (check.overlaps != 0)
    throw std::logic_error("make_isotropic: internal error: " + std::to_string(check.overlaps) +
                           " overlapping pairs left where the run counted none");
  out.order_parameter = order_parameter(axis_moments(p, p.size())).S;
  out.min_distance = std::min(shape.diameter, check.min_gap);
  out.seconds = elapsed();
  out.reached = true;
  if (report) *report = out;
  return p;
}

}  // namespace hardrod
