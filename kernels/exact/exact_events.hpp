// What the exact method's two ways through a step's events share (exact_collisions.hpp): the
// clusters' passes (exact_clusters.cpp) and the one queue (exact_queue.cpp), the one core both
// drive: events and their order, the bodies' flights and slots, the search of a pair's first
// contact and the impulse when it touches. Internal to kernels/exact/.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "kernels/contact_detection.hpp"
#include "kernels/exact/exact_collisions.hpp"

namespace hardrod::exact_events {

inline constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// An upper bound on how fast any point of a body moves: |v| + L/2 |w|, with the relative
// 1e-12 that refresh_motion's growth carries for the rounding. A sphere's spin moves no point
// of it (h = 0: the term is 0, and |v| + 0 is |v|), so its root is not taken.
inline double point_speed(const Flight &f, double h) {
  return (norm(f.v) + (h > 0.0 ? h * norm(f.w) : 0.0)) * (1.0 + 1e-12);
}

// A predicted contact (or, with `resume`, a search that used up its iterations and goes on
// from t) of the bodies in slots a and b, valid while neither has changed since.
struct Event {
  double t = 0.0;
  std::int64_t id_a = 0, id_b = 0;  // canonical order: id_a < id_b
  std::uint32_t a = 0, b = 0;
  std::uint32_t version_a = 0, version_b = 0;
  bool resume = false;
};
// Earliest first; ties by ids, so the order does not depend on the order of insertion.
struct Later {
  bool operator()(const Event &x, const Event &y) const {
    if (x.t != y.t) return x.t > y.t;
    if (x.id_a != y.id_a) return x.id_a > y.id_a;
    return x.id_b > y.id_b;
  }
};

// The step's events by time, ties by ids (Later), as a heap would give them, in a calendar:
// buckets of equal width over [0, dt], each a short chain of events, unsorted. The bucket of t,
// floor(t n / dt), never decreases with t (a product by a positive constant rounds
// monotonically), so the earliest event is the earliest of the first bucket that holds any.
// Events come no earlier than the last one taken (predictions run from its time on), so the
// cursor only moves on (it moves back if one did). n is about a quarter of the events
// expected: a few per bucket (hard spheres at N = 32768: 4096 heads, 16 kB, for ~15000
// candidates a step), where a heap of 48-byte events took log2(n) moves per push and pop.
// The one queue's (exact_queue.cpp); tests/kernels/test_exact_collisions.cpp checks it
// against a heap.
class EventCalendar {
 public:
  void start(double dt, std::size_t expected) {
    std::size_t n = 16;
    while (4 * n < expected && n < (std::size_t{1} << 16)) n *= 2;
    head_.assign(n, kNone);
    pool_.clear();
    next_.clear();
    scale_ = static_cast<double>(n) / dt;
    cursor_ = 0;
    size_ = 0;
  }
  bool empty() const { return size_ == 0; }
  void push(const Event &e) {
    const std::size_t k = bucket(e.t);
    next_.push_back(head_[k]);
    head_[k] = static_cast<std::uint32_t>(pool_.size());
    pool_.push_back(e);
    cursor_ = std::min(cursor_, k);
    ++size_;
  }
  Event pop() {
    while (head_[cursor_] == kNone) ++cursor_;
    // The earliest of the chain, and the link that points at it.
    std::uint32_t *link = &head_[cursor_], *best = link;
    for (std::uint32_t at = *link; at != kNone; at = *link) {
      if (Later()(pool_[*best], pool_[at])) best = link;
      link = &next_[at];
    }
    const std::uint32_t taken = *best;
    *best = next_[taken];
    --size_;
    return pool_[taken];
  }

 private:
  std::size_t bucket(double t) const {
    const double x = t * scale_;  // NaN and t >= dt: the last bucket
    const std::size_t last = head_.size() - 1;
    return x >= 0.0 && x < static_cast<double>(last) ? static_cast<std::size_t>(x)
                                                     : (x < 0.0 ? 0 : last);
  }
  std::vector<std::uint32_t> head_, next_;
  std::vector<Event> pool_;
  double scale_ = 0.0;
  std::size_t cursor_ = 0, size_ = 0;
};

// What every cluster reads.
struct Context {
  const Particles &p;
  const Box &box;
  Vec3 inverse;
  const Shape &shape;
  const NeighborList &list;
  const std::vector<std::uint32_t> &group_of;  // by body: its cluster, kNone if none
  double dt;
  const ExactSettings &settings;
  // By body: a flown body's overrun, written as its cluster lands (ExactScratch::overrun; a
  // cluster's bodies are its own, so threads write apart), else 0.
  double *overrun;
};

// What moves body b to its periodic image nearest body a at the step's start (the image does
// not change within a step: the list's pairs are far shorter than half the box).
inline Vec3 image_shift(const Context &cx, std::uint32_t a, std::uint32_t b) {
  const Vec3 raw = cx.p.position(b) - cx.p.position(a);
  return cx.box.minimum_image(raw, cx.inverse) - raw;
}

// The first contact from t of flight fa and flight fb moved by `shift` (fa's body has the lower
// id), counted in `stats` (`again`: after a velocity changed). False where the pair cannot touch
// in the step; else the event's time `at`, and `resume` where the search used up its iterations
// and goes on from there.
inline bool search_pair(const Context &cx, const Flight &fa, Flight fb, const Vec3 &shift, double t,
                        bool again, ExactStats &stats, double &at, bool &resume) {
  fb.x = fb.x + shift;
  const ContactTime ct = first_contact(fa, fb, cx.shape.half_length(), cx.shape.diameter, t, cx.dt,
                                       cx.settings.contact);
  ++stats.searches;
  stats.repredictions += again;
  stats.root_iterations += ct.iterations;
  if (!ct.found && ct.converged) return false;
  stats.unconverged += !ct.converged;
  at = ct.t;
  resume = !ct.found;
  return true;
}

// Candidate::apart holds: the detection's margin is above the search's tolerance.
inline bool screened(const ExactSettings &settings) {
  return settings.contact.tolerance < kApartMargin;
}

// Two flights touching now (fa has the lower id; xb: b's centre at its image nearest a): the
// elastic, frictionless impulse given if they close, with its virial J n . (x_a - x_b); else
// (a graze) nothing changes, and `gap` is their surface gap.
struct Touch {
  bool closing = false;
  double virial = 0.0;
  double gap = 0.0;
};

// Spheres: give_impulse's arithmetic without the segments and the arms. A sphere's arms are 0
// times a cross product and its flights carry no spin (start_flight), so those terms add only
// zeros: the same bits, but for the sign of a zero where the centres share a coordinate exactly.
inline Touch give_sphere_impulse(Flight &fa, Flight &fb, const Vec3 &xb, const Shape &shape) {
  const Vec3 r = xb - fa.x;
  const SegmentClosest sc{0.0, 0.0, -r, norm2(r)};  // segment_closest's, for h = 0
  const Vec3 normal = contact_normal(sc, r, fa.e, fb.e);
  const double u = dot(normal, fa.v - fb.v);
  Touch out;
  if (!(u < 0.0)) {
    out.gap = std::sqrt(sc.dist2) - shape.diameter;
    return out;
  }
  const double inv_m = 1.0 / shape.mass;
  const double j = -2.0 * u / (2.0 * inv_m);  // give_impulse's inverse mass with no arms
  fa.v = fa.v + (j * inv_m) * normal;
  fb.v = fb.v - (j * inv_m) * normal;
  out.closing = true;
  out.virial = j * dot(normal, fa.x - xb);
  return out;
}

inline Touch give_impulse(Flight &fa, Flight &fb, const Vec3 &xb, const Shape &shape) {
  const double h = shape.half_length();
  if (h == 0.0) return give_sphere_impulse(fa, fb, xb, shape);
  const Vec3 r = xb - fa.x;
  const SegmentClosest sc = segment_closest_inline(r, fa.e, h, fb.e, h);
  Contact c;
  contact_geometry(sc, r, fa.e, fb.e, shape, c);
  const double u = dot(c.normal, fa.v - fb.v) + dot(fa.w, c.arm_i) - dot(fb.w, c.arm_j);
  Touch out;
  if (!(u < 0.0)) {
    out.gap = std::sqrt(sc.dist2) - shape.diameter;
    return out;
  }
  const double inv_m = 1.0 / shape.mass, inv_i = shape.inverse_inertia();
  const double j = -2.0 * u / c.inverse_mass;
  fa.v = fa.v + (j * inv_m) * c.normal;
  fb.v = fb.v - (j * inv_m) * c.normal;
  fa.w = fa.w + (j * inv_i) * c.arm_i;
  fb.w = fb.w - (j * inv_i) * c.arm_j;
  out.closing = true;
  out.virial = j * dot(c.normal, fa.x - xb);
  return out;
}

// After a graze at t (the search saw the pair closing, the impulse's geometry, rounded
// differently, does not; nothing changed): the time `from` the pair is searched again, a moment
// later, so that a pass always moves on (the gap can shrink by at most ~1e-12 D meanwhile).
// False for a pair that overlaps already (a start file from the midpoint method) and recedes:
// it is left to part.
inline bool search_after_graze(const Context &cx, const Touch &touch, double t, double &from) {
  if (!(touch.gap > -cx.settings.contact.tolerance)) return false;
  from = std::min(cx.dt, t + 1e-9 * cx.dt);
  return true;
}

// A flight flown on to time t (it then starts there), with the bound on how far any point of
// the body moved grown by the way. A sphere's axis does not turn, as in its free flight
// (drift): the same bits, without the rotation's arithmetic.
inline void fly_on(Flight &f, double &moved, double t, double h) {
  moved += point_speed(f, h) * (t - f.t0);
  f.x = f.position(t);
  if (h > 0.0) f.e = f.axis(t);
  f.t0 = t;
}

// Body b's free flight from the step's start. Without `turns` (a sphere) its axis and spin
// are not loaded (zero in the flight: two of the four scattered loads of a body's state):
// nothing reads them. A sphere's flight keeps its axis (fly_on), its contact time is a
// closed form of centres and velocities (sphere_contact), its impulse has no arm, so no
// torque (give_impulse: its arms are 0 times a cross product, whatever the axis), and its
// landing writes neither back (land_flown): its axis and spin stay as they were.
inline Flight start_flight(const Particles &p, std::uint32_t b, bool turns) {
  if (!turns) return {p.position(b), {}, p.velocity(b), {}, 0.0};
  return {p.position(b), p.axis(b), p.velocity(b), p.angular_velocity(b), 0.0};
}

// The bodies a pass has met, by slot: each one's flight, how far it may have moved, its
// version (how often its velocity changed: a prediction holds while both versions do), and
// the collisions in which it was the lower-id body, with their virial.
struct Slots {
  std::vector<Flight> flight;
  std::vector<double> moved;
  std::vector<std::uint32_t> version;
  std::vector<long long> collisions;
  std::vector<ExactSum> virial;

  void clear() {
    flight.clear();
    moved.clear();
    version.clear();
    collisions.clear();
    virial.clear();
  }
  // A slot for a body in free flight from the step's start (a sphere's without axis and spin:
  // start_flight without `turns`).
  std::uint32_t add(const Particles &p, std::uint32_t b, bool turns) {
    flight.push_back(start_flight(p, b, turns));
    moved.push_back(0.0);
    version.push_back(0);
    collisions.push_back(0);
    virial.push_back(ExactSum());
    return static_cast<std::uint32_t>(flight.size() - 1);
  }
  void fly_to(std::uint32_t s, double t, double h) { fly_on(flight[s], moved[s], t, h); }

  // Slots a and b touching at t (a has the lower id; `shift` moves b to its image nearest a):
  // both flown there and the impulse given (give_impulse), counted in `stats` and, if the pair
  // closed, in a's collisions, with both versions moved on. A graze is counted as one.
  Touch collide(std::uint32_t a, std::uint32_t b, double t, const Vec3 &shift, const Shape &shape,
                ExactStats &stats) {
    fly_to(a, t, shape.half_length());
    fly_to(b, t, shape.half_length());
    const Touch touch = give_impulse(flight[a], flight[b], flight[b].x + shift, shape);
    if (!touch.closing) {
      ++stats.grazes;
      return touch;
    }
    stats.virial.add(touch.virial);
    virial[a].add(touch.virial);
    ++stats.collisions;
    ++collisions[a];
    ++version[a];
    ++version[b];
    return touch;
  }

  // Slot s of body b flown to the step's end dt, appended to `flown` (made in place: a
  // record of 152 bytes per body): its overrun is how much further it may have moved than its
  // free flight's bound (2 grow) allowed.
  const FlownBody &land(std::uint32_t s, std::uint32_t b, double dt, const Particles &p, double h,
                        std::vector<FlownBody> &flown) {
    fly_to(s, dt, h);
    const Flight &f = flight[s];
    const double overrun = std::max(0.0, moved[s] - 2.0 * p.grow[b]);
    return flown.emplace_back(b, f.x, f.e, f.v, f.w, overrun, collisions[s], virial[s]);
  }
};

// Whether listed pair `pair` of bodies a and b could touch within the step when each may end
// it beyond its free flight's bound by its overrun: first the slack with the real bounds, then
// the distance at the step's start against the two bodies' reaches. `false` is a proof.
inline bool overrun_could_touch(const Particles &p, const Box &box, const Vec3 &inverse,
                                const Shape &shape, const ListedPair &pair, std::uint32_t a,
                                double overrun_a, std::uint32_t b, double overrun_b) {
  const double *bound = p.motion_bound.data();
  const double first = pair.first == a ? overrun_a : overrun_b;
  const double second = pair.first == a ? overrun_b : overrun_a;
  const double moved = bound[pair.first] + first + bound[pair.second] + second;
  if (moved < pair.recheck_at) return false;
  Contact c;
  double d = 0.0;
  const double reach =
      (2.0 * p.grow[a] + overrun_a) + (2.0 * p.grow[b] + overrun_b) + kDistanceSafetyMargin;
  return make_contact(p, box, inverse, shape, a, b, c, d, reach);
}

// The step's events in one queue instead of by cluster (exact_queue.cpp): the candidates' and
// the joins' pairs, and the pairs a body's overrun could bring to touch, with a body outside
// them (`confined` false, one rank's whole step) or only between their bodies (`confined`:
// collide_once, where the caller checks the rest). False where a body passed the event cap's
// bound: nothing is written then (flown is left empty), and the caller solves by clusters.
bool solve_in_one_queue(const Context &cx, const std::vector<Candidate> &candidates,
                        const std::vector<BodyPair> &joins, bool confined, ExactScratch &scratch,
                        ExactStats &stats, std::vector<FlownBody> &flown);

// The step by clusters (exact_clusters.cpp): the clusters of the candidates (no spares) and
// `joins`, each solved by its own pass, their counts added to `stats` and their flown bodies to
// `flown`. With `regrow`, clusters whose overruns could reach each other are joined and solved
// again until none can (one rank's whole step); without, once (several ranks: the caller
// checks the overruns).
void solve_by_clusters(const Particles &p, const Box &box, const Shape &shape,
                       const NeighborList &list, const std::vector<Candidate> &candidates,
                       const std::vector<BodyPair> &joins, double dt, const ExactSettings &settings,
                       bool regrow, ExactScratch &scratch, ExactStats &stats,
                       std::vector<FlownBody> &flown);

}  // namespace hardrod::exact_events
