// The exact method's events of a whole step in one queue (exact_events.hpp), on one thread: one
// rank's whole step, or on several ranks the clusters a rank owns whole.
#include <algorithm>

#include "kernels/exact/exact_events.hpp"

namespace hardrod::exact_events {
namespace {

// The whole step's events in one queue, by time (ties by ids), on one thread: the clusters'
// events without the clusters. A prediction depends only on the two bodies' flights and the
// time it starts from, so the events are those of the clusters' passes, and the end states
// their bits. A body that changes velocity is predicted again against its candidate partners;
// and where its new velocity could carry it beyond its free flight's bound by the step's end
// (its overrun so far), its other listed pairs are checked, as the clusters' overrun check
// does, against that overrun and the partner's: a pair that could then touch joins the
// candidates (an "extra" pair) for the rest of the step. Every pair that touches in the end is
// one of them: each body's last check was made with overruns at least its final one, and
// its partner's. With an overrun allowance A (ExactSettings::overrun_allowance), the detection
// has made partners (spares) of the pairs that overruns of A each could bring to touch: a
// pair beyond them touches only if one of its bodies overruns by more than A, so only such a
// body's pairs are checked, with A for a partner that overran less. Confined (several ranks), the
// extra pairs stay between the bodies of the candidates and joins given, and the caller's overrun
// check sees to the others, as it does for clusters. A body that takes part in more than twice
// events_per_body events stops the pass (a cluster past its cap, events_per_body per body, must
// hold one): the caller then solves the step by clusters, whose fallback it is.
//
// A pair the detection proved apart all step (Candidate::proven: its surface gap stays above
// that proof plus kApartMargin along the two free flights) is not searched again when a body's
// velocity changes while the proof, less how far the new flights can stray from the old ones,
// stays above the tolerance: a point of a body whose velocity and spin change by dv and dw at t
// strays from where its old flight would take it by at most (|dv| + h |dw|) (s - t) at s (the
// two rotations about w and w + dw differ by at most |dw| (s - t)), so the gap stays above the
// tolerance plus kApartMargin, and the search would find nothing. The events, and so the
// trajectory, are the same bits; only the searches are fewer (ExactStats::kept_apart: about
// 70 % of the searches again of a body's other partners in the nematic).
class StepPass {
 public:
  bool run(const Context &cx, ExactScratch &scratch, const std::vector<Candidate> &candidates,
           const std::vector<BodyPair> &joins, bool confined, ExactStats &stats,
           std::vector<FlownBody> &flown) {
    cx_ = &cx;
    scratch_ = &scratch;
    confined_ = confined;
    turns_ = !cx.shape.is_sphere();
    clear();
    scratch.first_edge.resize(cx.list.active, kNone);
    for (const Candidate &c : candidates) link(c.i, c.j, true, c.proven);  // id_i < id_j
    for (const auto &[a, b] : joins)
      if (!partners(a, b)) link(a, b, cx.p.id[a] < cx.p.id[b], 0.0f);
    const bool done = pass(candidates, screened(cx.settings));
    if (done) {
      stats += stats_;
      land(flown);
    }
    for (const std::uint32_t b : bodies_) scratch_->label[b] = kNone;
    unlink();
    return done;
  }

 private:
  // Storage kept from step to step: a step allocates nothing once the queue has grown.
  void clear() {
    bodies_.clear();
    slots_.clear();
    checked_.clear();
    events_.clear();
    edges_.clear();
    stats_ = {};
  }

  // Each body's partners, a list through edges_ from first_edge[body] (latest first): the other
  // bodies of its candidates, joins and extra pairs, each with whether its id is the higher
  // (`a_lower`: id[a] < id[b]), so that a prediction needs not load the two ids to order them.
  // Only the bodies linked are touched, and unlink clears them. Both edges of a pair (2k and
  // 2k + 1: each other's k ^ 1) hold its proof (Candidate::proven; 0: none).
  void link(std::uint32_t a, std::uint32_t b, bool a_lower, float proven) {
    std::vector<std::uint32_t> &first = scratch_->first_edge;
    edges_.push_back({b, first[a], proven, a_lower});
    first[a] = static_cast<std::uint32_t>(edges_.size() - 1);
    edges_.push_back({a, first[b], proven, !a_lower});
    first[b] = static_cast<std::uint32_t>(edges_.size() - 1);
  }
  void unlink() {
    for (const Edge &e : edges_) scratch_->first_edge[e.other] = kNone;
  }

  bool pass(const std::vector<Candidate> &candidates, bool screened) {
    queue_.start(cx_->dt, candidates.size());
    for (const Candidate &c : candidates)
      if (!c.spare && !(screened && c.apart)) predict(c.i, c.j, 0.0, false);
    const long long cap = 2 * cx_->settings.events_per_body;
    while (!queue_.empty()) {
      const Event ev = queue_.pop();
      if (ev.version_a != version(ev.a) || ev.version_b != version(ev.b)) continue;
      ++stats_.events;
      const std::uint32_t sa = slot(ev.a), sb = slot(ev.b);
      if (++events_[sa] > cap || ++events_[sb] > cap) return false;
      if (ev.resume)
        predict(ev.a, ev.b, ev.t, false);
      else
        collide(ev.a, ev.b, sa, sb, ev.t);
    }
    return true;
  }

  std::uint32_t version(std::uint32_t body) const {
    const std::uint32_t s = scratch_->label[body];
    return s == kNone ? 0 : slots_.version[s];
  }

  // Body b's slot, made when it first takes part in an event, with its flight from the
  // step's start.
  std::uint32_t slot(std::uint32_t b) {
    std::uint32_t &s = scratch_->label[b];
    if (s != kNone) return s;
    s = slots_.add(cx_->p, b, turns_);
    bodies_.push_back(b);
    checked_.push_back(0.0);
    events_.push_back(0);
    return s;
  }

  // Body b's flight (a sphere's without axis and spin: start_flight).
  Flight flight(std::uint32_t b) const {
    const std::uint32_t s = scratch_->label[b];
    return s == kNone ? start_flight(cx_->p, b, turns_) : slots_.flight[s];
  }

  // The first contact of bodies a and b (a with the lower id) from t, queued if there is one in
  // the step.
  void predict(std::uint32_t a, std::uint32_t b, double t, bool again) {
    double at = 0.0;
    bool resume = false;
    if (!search_pair(*cx_, flight(a), flight(b), image_shift(*cx_, a, b), t, again, stats_, at,
                     resume))
      return;
    queue_.push({at, cx_->p.id[a], cx_->p.id[b], a, b, version(a), version(b), resume});
  }

  // Bodies a and b (slots sa, sb; a has the lower id) touching at t: the impulse, then, where
  // the pair closed, every partner of the two searched again (unless its proof still holds).
  void collide(std::uint32_t a, std::uint32_t b, std::uint32_t sa, std::uint32_t sb, double t) {
    const Flight before_a = slots_.flight[sa], before_b = slots_.flight[sb];
    const Touch touch = slots_.collide(sa, sb, t, image_shift(*cx_, a, b), cx_->shape, stats_);
    if (!touch.closing) {
      double from = 0.0;
      if (search_after_graze(*cx_, touch, t, from)) predict(a, b, from, true);
      return;
    }
    check_overrun(a, sa, t);
    check_overrun(b, sb, t);
    predict_partners(a, b, kNone, stray(before_a, slots_.flight[sa], t), t);
    predict_partners(b, a, a, stray(before_b, slots_.flight[sb], t), t);
  }

  // How far any point of a body whose flight changed from `before` to `after` at t can be from
  // where `before` would have taken it by the step's end (the queue's comment above), with the
  // relative 1e-12 of point_speed for the rounding.
  double stray(const Flight &before, const Flight &after, double t) const {
    const double h = cx_->shape.half_length();
    const double turn = h > 0.0 ? h * norm(after.w - before.w) : 0.0;
    return (norm(after.v - before.v) + turn) * (cx_->dt - t) * (1.0 + 1e-12);
  }

  // A partner of `body` it is predicted against: a candidate partner or an extra pair.
  bool partners(std::uint32_t body, std::uint32_t other) const {
    for (std::uint32_t k = scratch_->first_edge[body]; k != kNone; k = edges_[k].next)
      if (edges_[k].other == other) return true;
    return false;
  }

  // How far beyond its free flight's bound a body may end the step: the overrun it would have
  // if it flew on from t unchanged (the clusters' FlownBody::overrun, the same operations).
  double overrun_from(std::uint32_t s, std::uint32_t body, double t) const {
    return slots_.moved[s] +
           point_speed(slots_.flight[s], cx_->shape.half_length()) * (cx_->dt - t) -
           2.0 * cx_->p.grow[body];
  }
  // The largest overrun a body's listed pairs were checked with (0: never, or no slot), and
  // at least the allowance, which the detection's spares cover.
  double checked(std::uint32_t body) const {
    const std::uint32_t s = scratch_->label[body];
    return std::max(cx_->settings.overrun_allowance, s == kNone ? 0.0 : checked_[s]);
  }

  // Where body's overrun from t is above the allowance and the one it was last checked with,
  // its listed pairs that are not yet partners, checked as OverrunCheck does: those that could
  // touch become extra pairs.
  void check_overrun(std::uint32_t body, std::uint32_t s, double t) {
    const double overrun = overrun_from(s, body, t);
    if (!(overrun > checked_[s]) || !(overrun > cx_->settings.overrun_allowance)) return;
    checked_[s] = overrun;
    const NeighborList &list = cx_->list;
    const std::uint32_t begin = list.pairs_start[body], end = list.pairs_end[body];
    // Every load below is scattered (a miss each at N = 32768): asked for all at once first.
    for (std::uint32_t q = begin; q < end; ++q) {
      const std::uint32_t other = list.pair_partner[q];
      __builtin_prefetch(&list.pairs[list.pair_index[q]]);
      __builtin_prefetch(&cx_->p.motion_bound[other]);
      __builtin_prefetch(&scratch_->label[other]);
    }
    for (std::uint32_t q = begin; q < end; ++q) {
      const std::uint32_t other = list.pair_partner[q];
      if (confined_ && scratch_->first_edge[other] == kNone) continue;  // not this pass's
      if (!overrun_could_touch(cx_->p, cx_->box, cx_->inverse, cx_->shape,
                               list.pairs[list.pair_index[q]], body, overrun, other,
                               checked(other)) ||
          partners(body, other))
        continue;
      link(body, other, cx_->p.id[body] < cx_->p.id[other], 0.0f);
      ++stats_.extra_pairs;
    }
  }

  // The partners of `body` (but `skip`) after its velocity changed at t in a collision with
  // `partner`, whose flights may stray by `strayed`: each searched again from t, unless its
  // proof, less `strayed`, still keeps it apart. (The pair just collided has no proof left.)
  void predict_partners(std::uint32_t body, std::uint32_t partner, std::uint32_t skip,
                        double strayed, double t) {
    for (std::uint32_t k = scratch_->first_edge[body]; k != kNone; k = edges_[k].next) {
      const Edge &e = edges_[k];
      if (e.other == skip) continue;
      const double left = e.other == partner ? 0.0 : e.proven - strayed;
      const bool kept = left > cx_->settings.contact.tolerance;
      // Rounded to a float and down by a part in 10^6 (over its 6e-8): still below.
      edges_[k].proven = edges_[k ^ 1].proven =
          kept ? static_cast<float>(left) * (1.0f - 1e-6f) : 0.0f;
      if (kept) {
        ++stats_.kept_apart;
        continue;
      }
      if (e.other_higher)
        predict(body, e.other, t, true);
      else
        predict(e.other, body, t, true);
    }
  }

  // The bodies whose velocity changed, flown to the step's end (in the order of their first
  // events: the order of the flown list changes nothing).
  void land(std::vector<FlownBody> &flown) {
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
      if (slots_.version[s] != 0)
        slots_.land(s, bodies_[s], cx_->dt, cx_->p, cx_->shape.half_length(), flown);
  }

  const Context *cx_ = nullptr;
  bool confined_ = false;            // extra pairs only between bodies of the candidates and joins
  bool turns_ = true;                // rods; spheres' flights carry no axis or spin (start_flight)
  ExactScratch *scratch_ = nullptr;  // label: a body's slot (kNone: none); first_edge
  Slots slots_;
  std::vector<std::uint32_t> bodies_;  // by slot
  std::vector<double> checked_;  // the largest overrun the body's listed pairs were checked with
  std::vector<long long> events_;
  struct Edge {
    std::uint32_t other, next;  // next: the body's next edge, kNone at the end
    float proven;               // the pair's proof (Candidate::proven), less its bodies' strays
    bool other_higher;          // the other body's id is the higher
  };
  std::vector<Edge> edges_;
  EventCalendar queue_;
  ExactStats stats_;
};

}  // namespace

bool solve_in_one_queue(const Context &cx, const std::vector<Candidate> &candidates,
                        const std::vector<BodyPair> &joins, bool confined, ExactScratch &scratch,
                        ExactStats &stats, std::vector<FlownBody> &flown) {
  thread_local StepPass pass;
  return pass.run(cx, scratch, candidates, joins, confined, stats, flown);
}

}  // namespace hardrod::exact_events
