// The free flight (see the header): the motion constants of each body, the drift of a block
// of bodies (a vector loop, with a scalar pass for the rare large rotation angle), its
// threaded callers, and the flight to the midpoint fused with the detection there.
#include "kernels/free_flight.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace hardrod {

namespace {

// Rotation angles up to this use the power series below, which are exact to double
// precision there; larger angles (|w| dt/2 > 0.1, far beyond any sensible dt) take the
// library sin and cos in a scalar pass.
constexpr double kSeriesAngle = 0.1;

// sin(a)/a and (1 - cos a)/a^2 as polynomials in a^2: only + and *, so vector lanes and
// scalar code give identical bits, and there is no division by |w|.
inline double sinc_series(double a2) {
  return 1.0 +
         a2 * (-1.0 / 6 +
               a2 * (1.0 / 120 +
                     a2 * (-1.0 / 5040 + a2 * (1.0 / 362880 + a2 * (-1.0 / 39916800 +
                                                                    a2 * (1.0 / 6227020800.0))))));
}
inline double versine_series(double a2) {
  return 0.5 +
         a2 * (-1.0 / 24 +
               a2 * (1.0 / 720 + a2 * (-1.0 / 40320 +
                                       a2 * (1.0 / 3628800 + a2 * (-1.0 / 479001600 +
                                                                   a2 * (1.0 / 87178291200.0))))));
}

// e' = e cos a + (w x e) h sinc(a) + w (w.e) h^2 vers(a)/a^2 with a = |w| h: Rodrigues'
// formula about the unit vector w/|w|, written without dividing by |w|.
struct Rotation {
  double cos_a, sin_over_w, vers_over_w2;
};

// From a2 = (|w| h)^2 and the two series at a2 (stored per body: refresh_motion).
inline Rotation series_rotation(double a2, double h, double sinc, double vers) {
  return {1.0 - a2 * vers, h * sinc, h * h * vers};  // vers = (1 - cos a) / a^2
}

inline Rotation library_rotation(double w2, double h) {
  const double w = std::sqrt(w2);
  const double a = w * h;
  return {std::cos(a), std::sin(a) / w, (1.0 - std::cos(a)) / w2};
}

// The rotation is orthogonal to round-off, so |e| stays 1 to ~1e-16 per step; the
// square root and division of a renormalisation (the costliest part of the half step) are
// left to restore_rotor_constraints (rotor_constraints.hpp), every kConstraintInterval steps.
inline void rotate_axis(double &ex, double &ey, double &ez, double wx, double wy, double wz,
                        const Rotation &r) {
  const double wdote = wx * ex + wy * ey + wz * ez;
  const double nx = ex * r.cos_a + (wy * ez - wz * ey) * r.sin_over_w + wx * wdote * r.vers_over_w2;
  const double ny = ey * r.cos_a + (wz * ex - wx * ez) * r.sin_over_w + wy * wdote * r.vers_over_w2;
  const double nz = ez * r.cos_a + (wx * ey - wy * ex) * r.sin_over_w + wz * wdote * r.vers_over_w2;
  ex = nx;
  ey = ny;
  ez = nz;
}

// The motion constants of body i (Particles::grow, turn_*): the costly part of a half step's
// arithmetic (two square roots, two series), which depends on v, w, the shape and dt only, so
// it is computed when a velocity changes rather than in every pass.
template <bool Rotate>
inline void motion_constants(Particles &p, long i, double arm, double half_dt,
                             double max_series_w2) {
  const double speed = std::sqrt(p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i]);
  if constexpr (Rotate) {
    const double w2 = p.wx[i] * p.wx[i] + p.wy[i] * p.wy[i] + p.wz[i] * p.wz[i];
    // The chord a point at distance L/2 from the centre sweeps is at most L/2 |w| dt/2.
    // A relative 1e-12 on top covers the rounding of this sum and of the rotation.
    p.grow[i] = (speed + arm * std::sqrt(w2)) * half_dt * (1.0 + 1e-12);
    // A large angle gets the identity (a2 = 0, h = 0) and its rotation in drift's scalar
    // pass.
    const bool series = w2 <= max_series_w2;
    const double h = series ? half_dt : 0.0;
    const double a2 = (series ? w2 : 0.0) * h * h;
    p.turn_sinc[i] = sinc_series(a2);
    p.turn_vers[i] = versine_series(a2);
  } else {
    p.grow[i] = speed * half_dt * (1.0 + 1e-12);
  }
}

double max_series_w2(double half_dt) { return (kSeriesAngle / half_dt) * (kSeriesAngle / half_dt); }

// Spheres (Rotate = false) skip the rotation entirely: a scene pays only for what it uses.
// Halves = 2 is the second half of one step and the first half of the next in one pass:
// each half's additions and rotation are applied in turn, so the bits are those of two
// passes, with one load and store of every body. The motion constants are read, not
// computed (refresh_motion). Bodies [lo, hi), no threads of its own (element-wise: any
// split gives the same bits).
// Grow = false (the exact method's flight) leaves the motion bounds alone: its step grew
// them before the flight (grow_bounds).
template <bool Rotate, int Halves, bool Grow = true>
double drift(Particles &p, long lo, long hi, double half_dt) {
  double *__restrict x = p.x.data(), *__restrict y = p.y.data(), *__restrict z = p.z.data();
  double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(), *__restrict ez = p.ez.data();
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
  const double *__restrict wx = p.wx.data(), *__restrict wy = p.wy.data(),
                           *__restrict wz = p.wz.data();
  const double *__restrict grow = p.grow.data(), *__restrict turn_sinc = p.turn_sinc.data(),
                           *__restrict turn_vers = p.turn_vers.data();
  double *__restrict bound = p.motion_bound.data();
  const double largest_series_w2 = max_series_w2(half_dt);
  long large_angles = 0;
  double largest = 0.0;

#pragma omp simd reduction(+ : large_angles) reduction(max : largest)
  for (long i = lo; i < hi; ++i) {
    const double dx = vx[i] * half_dt, dy = vy[i] * half_dt, dz = vz[i] * half_dt;
    double xi = x[i], yi = y[i], zi = z[i], bi = bound[i];
    const double gi = grow[i];
    if constexpr (Rotate) {
      const double w2 = wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i];
      // Branch-free so the loop vectorises: a large angle gets the identity here and its
      // rotation in the scalar pass below.
      const bool series = w2 <= largest_series_w2;
      large_angles += series ? 0 : 1;
      const double h = series ? half_dt : 0.0;
      const Rotation r =
          series_rotation((series ? w2 : 0.0) * h * h, h, turn_sinc[i], turn_vers[i]);
      double exi = ex[i], eyi = ey[i], ezi = ez[i];
      for (int h = 0; h < Halves; ++h) rotate_axis(exi, eyi, ezi, wx[i], wy[i], wz[i], r);
      ex[i] = exi;
      ey[i] = eyi;
      ez[i] = ezi;
    }
    for (int h = 0; h < Halves; ++h) {
      xi += dx;
      yi += dy;
      zi += dz;
      if constexpr (Grow) bi += gi;
    }
    x[i] = xi;
    y[i] = yi;
    z[i] = zi;
    if constexpr (Grow) bound[i] = bi;
    largest = largest > bi ? largest : bi;
  }
  if (large_angles > 0) {
    for (long i = lo; i < hi; ++i) {
      const double w2 = wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i];
      if (w2 > largest_series_w2) {
        const Rotation r = library_rotation(w2, half_dt);
        for (int h = 0; h < Halves; ++h) rotate_axis(ex[i], ey[i], ez[i], wx[i], wy[i], wz[i], r);
      }
    }
  }
  return largest;
}

}  // namespace

double drift_block(Particles &p, long lo, long hi, const Shape &shape, double half_dt, int halves) {
  if (shape.is_sphere())
    return halves == 2 ? drift<false, 2>(p, lo, hi, half_dt) : drift<false, 1>(p, lo, hi, half_dt);
  return halves == 2 ? drift<true, 2>(p, lo, hi, half_dt) : drift<true, 1>(p, lo, hi, half_dt);
}

void refresh_motion(Particles &p, long lo, long hi, const Shape &shape, double half_dt) {
  const double arm = shape.half_length();
  const double limit = max_series_w2(half_dt);
  if (shape.is_sphere()) {
#pragma omp simd
    for (long i = lo; i < hi; ++i) motion_constants<false>(p, i, arm, half_dt, limit);
  } else {
#pragma omp simd
    for (long i = lo; i < hi; ++i) motion_constants<true>(p, i, arm, half_dt, limit);
  }
}

void refresh_motion(Particles &p, std::size_t count, const Shape &shape, double half_dt) {
  const long n = static_cast<long>(count);
#pragma omp parallel num_threads(team_threads(n))
  {
    const auto [lo, hi] = team_block(n, omp_get_thread_num(), omp_get_num_threads());
    refresh_motion(p, lo, hi, shape, half_dt);
  }
}

void refresh_motion(Particles &p, const std::vector<std::uint32_t> &bodies, const Shape &shape,
                    double half_dt) {
  const double arm = shape.half_length();
  const double limit = max_series_w2(half_dt);
  if (shape.is_sphere())
    for (const std::uint32_t i : bodies) motion_constants<false>(p, i, arm, half_dt, limit);
  else
    for (const std::uint32_t i : bodies) motion_constants<true>(p, i, arm, half_dt, limit);
}

double free_flight(Particles &p, std::size_t count, const Shape &shape, double half_dt,
                   int halves) {
  const long n = static_cast<long>(count);
  const int nthreads = team_threads(n);
  std::vector<double> largest(nthreads, 0.0);
#pragma omp parallel num_threads(nthreads)
  {
    const auto [lo, hi] = team_block(n, omp_get_thread_num(), omp_get_num_threads());
    largest[omp_get_thread_num()] = drift_block(p, lo, hi, shape, half_dt, halves);
  }
  return *std::max_element(largest.begin(), largest.end());
}

double half_step(Particles &p, std::size_t count, const Shape &shape, double half_dt) {
  refresh_motion(p, count, shape, half_dt);
  return free_flight(p, count, shape, half_dt, 1);
}

double two_half_steps(Particles &p, std::size_t count, const Shape &shape, double half_dt) {
  refresh_motion(p, count, shape, half_dt);
  return free_flight(p, count, shape, half_dt, 2);
}

namespace {

// grow_bounds' pass; with Extra also the largest bound less extra[i], else that is the largest.
template <bool Extra>
GrownBounds grow_bounds_pass(Particles &p, std::size_t count, const double *__restrict extra) {
  const long n = static_cast<long>(count);
  double *__restrict bound = p.motion_bound.data();
  const double *__restrict grow = p.grow.data();
  double largest = 0.0, used = 0.0, fastest = 0.0, sum = 0.0;
#pragma omp simd reduction(max : largest, used, fastest) reduction(+ : sum)
  for (long i = 0; i < n; ++i) {
    const double b = (bound[i] + grow[i]) + grow[i];  // as drift's two halves add them
    bound[i] = b;
    largest = largest > b ? largest : b;
    if constexpr (Extra) {
      const double u = b - extra[i];
      used = used > u ? used : u;
    }
    const double step = grow[i] + grow[i];
    fastest = fastest > step ? fastest : step;
    sum += b;  // a NaN, which the maximum would drop, stays in the sum
  }
  GrownBounds out;
  out.largest = std::isfinite(sum) ? largest : sum;
  out.largest_used = Extra ? used : largest;
  out.fastest_step = fastest;
  return out;
}

}  // namespace

GrownBounds grow_bounds(Particles &p, std::size_t count, const double *extra) {
  return extra ? grow_bounds_pass<true>(p, count, extra)
               : grow_bounds_pass<false>(p, count, nullptr);
}

double grow_bounds(Particles &p, std::size_t count) {
  return grow_bounds_pass<false>(p, count, nullptr).largest;
}

void fly_step(Particles &p, std::size_t count, const Shape &shape, double half_dt) {
  const long n = static_cast<long>(count);
#pragma omp parallel num_threads(team_threads(n))
  {
    const auto [lo, hi] = team_block(n, omp_get_thread_num(), omp_get_num_threads());
    if (shape.is_sphere())
      drift<false, 2, false>(p, lo, hi, half_dt);
    else
      drift<true, 2, false>(p, lo, hi, half_dt);
  }
}

MidpointDetection advance_to_midpoint(Particles &p, std::size_t count, const Shape &shape,
                                      double half_dt, int halves, NeighborList &list,
                                      const Box &box, std::vector<Contact> &contacts) {
  const long n = static_cast<long>(count);
  const int nthreads = team_threads(n);
  // The watches are kept for exactly these bodies: detect in the same region.
  const bool watched =
      list.builds > 0 && list.watching && list.active == count && list.bodies == p.size();
  MidpointDetection out;
  std::vector<double> largest(static_cast<std::size_t>(nthreads), 0.0);
  WatchedDetection shared(watched ? nthreads : 0, box, shape);
  bool expired = true;
  const auto t0 = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point t1;
#pragma omp parallel num_threads(nthreads)
  {
    const int tid = omp_get_thread_num();
    const auto [lo, hi] = team_block(n, tid, omp_get_num_threads());
    largest[tid] = drift_block(p, lo, hi, shape, half_dt, halves);
#pragma omp barrier
#pragma omp master
    t1 = std::chrono::steady_clock::now();
    // Every thread reads the same maxima and decides alike.
    double all = 0.0;
    for (int t = 0; t < omp_get_num_threads(); ++t) all = std::max(all, largest[t]);
    const bool expired_here = neighbor_list_expired(list, all, list.bodies);
    if (tid == 0) expired = expired_here;
    if (watched && !expired_here) detect_watched_in_team(p, list, shared);
  }
  out.largest_bound = *std::max_element(largest.begin(), largest.end());
  out.drift_nanoseconds = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
  if (watched && !expired) {
    out.detected = true;
    out.stats = finish_watched_detection(p, list, shared, contacts);
  }
  return out;
}

}  // namespace hardrod
