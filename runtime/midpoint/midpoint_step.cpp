// The midpoint method's step (see the header): the first half to the midpoint, the detection
// there, the agreement and rebuild through the System, the local resolution, the step's
// tallies and the second half; its part of the report. The clusters across ranks are in
// spanning_clusters.cpp.
#include "runtime/midpoint/midpoint_step.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>

namespace hardrod {

MidpointStep::MidpointStep(const Scene &scene, const ParallelOptions &parallel)
    : results_exchange_(parallel.results_exchange) {
  solver_.tolerance = scene.solver_tolerance;
  solver_.max_iterations = static_cast<int>(scene.solver_max_iterations);
}

void MidpointStep::step(System &sys) {
  if (!at_midpoint_) reached_ = to_midpoint(sys, 1);  // 1. (with 2. when the list keeps watches)
  midpoint(sys, reached_);                            // 2.-5.
}

void MidpointStep::finish(System &sys, bool next_follows) {
  at_midpoint_ = next_follows;
  if (next_follows)
    reached_ = to_midpoint(sys, 2);  // 6., and the next step's 1.
  else
    second_half(sys);  // 6.
}

// Free flight to the midpoint (`halves` half steps) and the detection there when the list
// keeps its watches: one parallel region (advance_to_midpoint). Timed as integrate and
// detect.
MidpointDetection MidpointStep::to_midpoint(System &sys, int halves) {
  const Scene &scene = sys.scene();
  const auto start = ProgramClock::now();
  MidpointDetection m =
      advance_to_midpoint(sys.particles(), sys.advanced(), scene.shape, 0.5 * scene.dt, halves,
                          sys.list(), scene.box, contacts_);
  const long long all =
      std::chrono::duration_cast<std::chrono::nanoseconds>(ProgramClock::now() - start).count();
  sys.timers().add(Region::kIntegrate, m.drift_nanoseconds);
  if (m.detected) {
    sys.timers().add(Region::kDetect, all - m.drift_nanoseconds);
    sys.note_detection(m.stats);
  }
  return m;
}

// Phase 6 alone: half_step refreshes every body's motion constants itself, so a step() at a
// time does not depend on the refreshes within a burst, and the tests compare the two.
void MidpointStep::second_half(System &sys) {
  ScopedRegion r(sys.timers(), Region::kIntegrate);
  half_step(sys.particles(), sys.advanced(), sys.scene().shape, 0.5 * sys.scene().dt);
}

// Phases 2-5, with the bodies at the midpoint of the step.
void MidpointStep::midpoint(System &sys, const MidpointDetection &reached) {
  // 2. contacts, found before the step's one reduction so that it can also tell every rank
  // whether any contact touches a rank boundary this step. A rank whose own bounds already
  // expire the list skips this: it knows a rebuild follows.
  DetectionStats detected;
  bool boundary = false;
  if (!neighbor_list_expired(sys.list(), reached.largest_bound, sys.particles().size())) {
    detected = reached.detected ? reached.stats : detect(sys);
    boundary = touches_boundary(sys);
  }
  // 3.
  Agreement agreed = sys.agree(reached.largest_bound, boundary);
  if (sys.take_forced_rebuild()) agreed.rebuild = true;  // new cuts (the same on every rank)
  // 4.
  if (agreed.rebuild) {
    sys.rebuild();
    detected = detect(sys);  // a problem is reported at the next step's agreement
    if (sys.comm().size() == 1) sys.report_pending_problems();
  }
  // 5.
  std::vector<char> counted(contacts_.size(), 1);
  const ResolutionStats resolved = resolve(sys, agreed, counted);
  // Velocities that changed: the motion constants follow (all after a rebuild, which
  // brings bodies and renews the shadows; else the impulses' bodies, in resolve).
  if (agreed.rebuild) sys.refresh_all_motion();
  tally(sys, detected, resolved, counted);
}

// Phase 5: elastic impulses. Nothing to do in most steps at small dt: no contact here, and
// no exchange, which all ranks must join. Contacts' results travel between ranks only when
// some rank has a contact that involves a shadow or a body that other ranks hold (agreed),
// or the shadows were just renewed. Sets counted[k] for the contacts this rank counts.
ResolutionStats MidpointStep::resolve(System &sys, const Agreement &agreed,
                                      std::vector<char> &counted) {
  const bool exchange = sys.comm().size() > 1 && (agreed.boundary || agreed.rebuild);
  ResolutionStats resolved;
  if (contacts_.empty() && !exchange) return resolved;
  ScopedRegion r(sys.timers(), Region::kResolve);
  const Shape &shape = sys.scene().shape;
  const ContactClusters clusters = find_clusters(contacts_);
  if (sys.comm().size() == 1) {
    resolved = resolve_clusters(sys.particles(), shape, contacts_, clusters, {}, solver_);
    sys.interval().multi_contact_bodies += clusters.multi_contact_bodies;
  } else {
    resolved = resolve_on_ranks(sys, clusters, exchange);
    const std::size_t owned = sys.owned_count();
    // Each contact is counted once in the whole system: by the owner of its lower id.
    for (std::size_t k = 0; k < contacts_.size(); ++k) counted[k] = contacts_[k].i < owned;
    // Owned bodies only: their contacts are all seen here, each counted once.
    for (std::size_t b = 0; b < clusters.bodies.size(); ++b)
      sys.interval().multi_contact_bodies += clusters.bodies[b] < owned && clusters.degree[b] > 1;
  }
  if (!agreed.rebuild) {  // the bodies of the impulses, here and from other ranks
    changed_.clear();
    for (const Contact &c : contacts_) {
      changed_.push_back(c.i);
      changed_.push_back(c.j);
    }
    changed_.insert(changed_.end(), shared_in_.begin(), shared_in_.end());
    refresh_motion(sys.particles(), changed_, shape, 0.5 * sys.scene().dt);
  }
  shared_in_.clear();
  return resolved;
}

// Phase 5 on several ranks. Without an exchange every cluster is made of bodies only this
// rank holds: resolved here (5a). With one, the clusters with a body other ranks hold are
// put together across ranks (5b, resolve_across_ranks).
ResolutionStats MidpointStep::resolve_on_ranks(System &sys, const ContactClusters &clusters,
                                               bool exchange) {
  const std::vector<char> &shared = sys.shared();
  std::vector<char> local(clusters.count(), 1);
  if (exchange)
    for (std::size_t c = 0; c < clusters.count(); ++c)
      for (std::size_t k = clusters.start[c]; k < clusters.start[c + 1] && local[c]; ++k) {
        const Contact &ct = contacts_[clusters.order[k]];
        local[c] = !shared[ct.i] && !shared[ct.j];
      }
  ResolutionStats resolved = resolve_clusters(sys.particles(), sys.scene().shape, contacts_,
                                              clusters, local, solver_, sys.owned_count());
  if (exchange) {
    const ResolutionStats across = resolve_across_ranks(sys, clusters, local);
    resolved.clusters += across.clusters;
    resolved.iterations_max = std::max(resolved.iterations_max, across.iterations_max);
    resolved.unconverged += across.unconverged;
    sys.interval().solver_energy_change.add(across.energy_change);
  }
  return resolved;
}

// The step's contribution to the interval totals.
void MidpointStep::tally(System &sys, const DetectionStats &detected,
                         const ResolutionStats &resolved, const std::vector<char> &counted) const {
  IntervalTotals &t = sys.interval();
  const CollisionTally tally = tally_collisions(contacts_, counted);
  t.steps += 1;
  t.collisions += tally.collisions;
  t.virial += tally.virial;
  t.narrow_phase_tests += detected.narrow_phase_tests;
  for (std::size_t k = 0; k < contacts_.size(); ++k) t.contacts += counted[k];
  t.clusters += resolved.clusters;
  t.solver_iterations_max = std::max(t.solver_iterations_max, resolved.iterations_max);
  t.solver_unconverged += resolved.unconverged;
  t.max_depth = std::max(t.max_depth, detected.max_depth);
  t.solver_energy_change.add(resolved.energy_change);
}

// Contacts at the midpoint; an overlap beyond the tolerance is kept for the agreement.
DetectionStats MidpointStep::detect(System &sys) {
  ScopedRegion r(sys.timers(), Region::kDetect);
  const Scene &scene = sys.scene();
  const DetectionStats detected =
      detect_contacts(sys.particles(), scene.box, scene.shape, sys.list(), contacts_);
  sys.note_detection(detected);
  return detected;
}

// A contact crosses a rank boundary when one of its bodies is a shadow here or has shadow
// copies elsewhere: only then does another rank see it or need its result.
bool MidpointStep::touches_boundary(System &sys) const {
  if (sys.comm().size() == 1) return false;
  for (const Contact &c : contacts_)
    if (sys.shared()[c.i] || sys.shared()[c.j]) return true;
  return false;
}

// Collective: the clusters that spanned ranks, summed over ranks.
void MidpointStep::summarize(Communicator &comm, nlohmann::json &summary) const {
  const SpanningRecord &s = spanning_;
  summary["spanning_clusters"] = {{"exchanges", comm.sum("summary", s.exchanges)},
                                  {"resolved", comm.sum("summary", s.resolved)},
                                  {"multi_contact", comm.sum("summary", s.multi_contact)},
                                  {"put_together", comm.sum("summary", s.put_together)},
                                  {"from_results", comm.sum("summary", s.from_results)}};
}

void MidpointStep::print_parallel(const nlohmann::json &summary) const {
  const auto &sc = summary["spanning_clusters"];
  fmt::print(
      "clusters across ranks: {} resolved from merged contact records ({} with several "
      "contacts, {} needing another rank's contact), {} bodies set by the results "
      "exchange (summed over ranks)\n",
      sc["resolved"].get<long long>(), sc["multi_contact"].get<long long>(),
      sc["put_together"].get<long long>(), sc["from_results"].get<long long>());
}

}  // namespace hardrod
