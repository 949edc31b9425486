// The exact method's step (see the header): the bounds, the agreement and the rebuild or the
// list's extension, the detection of candidates and the collisions, the flight; the step's
// tallies and the method's part of the report. Phase 5 on several ranks is exact_ranks.cpp.
#include "runtime/exact/exact_step.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

namespace hardrod {

namespace {

// The one queue's overrun allowance per unit of dt (D per tau): a body whose velocity changes
// has its listed pairs checked only once its overrun passes this speed times dt, and the
// detection hands the queue the pairs within it as spares. Smaller, more collisions walk a
// body's pairs; larger, the detection lists spares that no collision needs
// (docs/performance.md).
constexpr double kOverrunAllowanceSpeed = 0.75;

// A list's bodies are extended (kernels/exact/list_extension.hpp) up to one extension per
// kExtensionShare bodies, then it is built again: past that a build costs less. A body is
// extended once its bound is within kExtensionLead of the fastest body's step of its reach, so
// that one that speeds up within the step seldom outruns it there (which has the step solved
// again on a new list).
constexpr long long kExtensionShare = 256;
constexpr double kExtensionLead = 0.5;

}  // namespace

ExactStep::ExactStep(const ParallelOptions &parallel, int ranks)
    : results_exchange_(parallel.results_exchange),
      extend_lists_(parallel.extend_lists && ranks == 1) {}

// Phases 1-5 with the bodies at the step's start.
void ExactStep::step(System &sys) {
  const Scene &scene = sys.scene();
  NeighborList &list = sys.list();
  double largest = bounds(sys);                  // 1.
  Agreement agreed = sys.agree(largest, false);  // 3.
  check_flight(sys, agreed.largest, "a velocity is NaN or infinite");
  const bool forced = sys.take_forced_rebuild();  // new cuts (the same on every rank)
  // One rank: the list expires body by body, extended first (a list for other bodies, or none
  // yet, is built). Where none can be extended (past the budget), built once a body reached
  // its reach.
  if (extend_lists_ && !forced && !neighbor_list_expired(list, 0.0, sys.particles().size())) {
    const double lead = kExtensionLead * grown_.fastest_step, half = 0.5 * scene.skin;
    agreed.rebuild = grown_.largest_used + lead >= half && !extend_list(sys, lead) &&
                     grown_.largest_used >= half;
  }
  if (forced) agreed.rebuild = true;
  if (agreed.rebuild) {  // 4.
    largest = sys.agreed_max(rebuild(sys));
    check_flight(sys, largest, "a body's flight in one step");
    if (neighbor_list_expired(list, largest, sys.particles().size()))
      sys.fail(
          fmt::format("step {}: at run.dt = {:g} a body's flight in one step ({:.4g} D) is more "
                      "than half the neighbour-list skin (run.skin = {:g}); use a smaller "
                      "run.dt or a larger run.skin",
                      sys.current_step() + 1, scene.dt, largest, scene.skin));
  }
  ExactStats stats;
  const DetectionStats detected = collide(sys, stats);  // 2., 5.
  tally(sys, detected, stats);
}

// Phase 6: every body flies the whole step; those whose velocity changed land on the end
// states of their own flights, and their motion constants follow their new velocities.
void ExactStep::finish(System &sys, bool) {
  const Shape &shape = sys.scene().shape;
  Particles &p = sys.particles();
  ScopedRegion r(sys.timers(), Region::kIntegrate);
  fly_step(p, sys.advanced(), shape, 0.5 * sys.scene().dt);
  land_flown(p, flown_, !shape.is_sphere());
  changed_.clear();
  for (const FlownBody &f : flown_) changed_.push_back(f.body);
  refresh_motion(p, changed_, shape, 0.5 * sys.scene().dt);
}

// The bodies' bounds grown by the step's flight; the largest (+infinity for a NaN or an
// infinite velocity, which shows here first), checked by the caller once agreed.
double ExactStep::bounds(System &sys) {
  ScopedRegion r(sys.timers(), Region::kIntegrate);
  const std::size_t n = sys.advanced();
  // Extra reaches only once a body was extended since the build (list_extension.hpp).
  const bool extra = extension_.extended > 0 && extension_.extra_reach.size() >= n;
  grown_ = grow_bounds(sys.particles(), n, extra ? extension_.extra_reach.data() : nullptr);
  const double largest = grown_.largest;
  return std::isfinite(largest) ? largest : std::numeric_limits<double>::infinity();
}

// Phase 4, and the step's flight in the new list's bounds; shadows come without their motion
// constants. A list that will be extended keeps what an extension measures.
double ExactStep::rebuild(System &sys) {
  sys.rebuild();
  if (extend_lists_)
    start_extension(extension_, sys.list(), sys.particles(), sys.owned_count(), sys.scene().shape);
  sys.refresh_all_motion();
  return bounds(sys);
}

// Phase 4 without a build (kernels/exact/list_extension.hpp): on one rank, the bodies whose bound
// came within `lead` of their reach get more of it and their new partners, up to one
// extension per kExtensionShare bodies in a list's life. False where the list is to be built
// instead.
bool ExactStep::extend_list(System &sys, double lead) {
  ScopedRegion r(sys.timers(), Region::kNeighborBuild);
  NeighborList &list = sys.list();
  const long long budget = static_cast<long long>(list.active) / kExtensionShare;
  return extend_neighbor_list(list, extension_, sys.particles(), sys.scene().box, sys.scene().shape,
                              lead, budget);
}

// An agreed bound that is not finite stops the run: never fly on with NaN.
void ExactStep::check_flight(const System &sys, double largest, const char *what) const {
  if (!std::isfinite(largest))
    sys.fail(fmt::format("step {}: {} (motion bound {}) at run.dt = {:g}", sys.current_step() + 1,
                         what, largest, sys.scene().dt));
}

// Phases 2 and 5. A body whose velocity changed may outrun the flight its bound was grown by;
// if that carries it past the list's skin, a pair the list does not hold could have touched:
// the step is solved again on a list built now (the bodies have not moved yet).
DetectionStats ExactStep::collide(System &sys, ExactStats &stats) {
  const Scene &scene = sys.scene();
  Particles &p = sys.particles();
  NeighborList &list = sys.list();
  const int ranks = sys.comm().size();
  // One thread takes the events of a step (on several ranks: of the clusters it owns whole) in
  // one queue; a team solves clusters in parallel (the same bits). One rank's queue takes the
  // spares of an overrun allowance (kOverrunAllowanceSpeed); ranks leave them out of their
  // clusters' protocol.
  settings_.one_queue = omp_get_max_threads() == 1;
  settings_.overrun_allowance =
      settings_.one_queue && ranks == 1 ? kOverrunAllowanceSpeed * scene.dt : 0.0;
  for (int attempt = 0;; ++attempt) {
    DetectionStats detected;
    {
      ScopedRegion r(sys.timers(), Region::kDetect);
      const StepAhead ahead{p.grow.data(), scene.dt, ranks > 1, settings_.overrun_allowance};
      detected = detect_candidates(p, scene.box, scene.shape, list, candidates_, ahead);
      sys.note_detection(detected);
    }
    double reach = 0.0;
    {
      ScopedRegion r(sys.timers(), Region::kResolve);
      if (ranks > 1) {
        stats = collide_on_ranks(sys, reach);
      } else {
        stats = collide_exactly(p, scene.box, scene.shape, list, candidates_, scene.dt, settings_,
                                scratch_, flown_);
        for (const FlownBody &f : flown_)  // against half the skin: less its extra reach
          reach =
              std::max(reach, p.motion_bound[f.body] + f.overrun - extra_reach(extension_, f.body));
      }
    }
    if (!neighbor_list_expired(list, reach, p.size())) return detected;
    if (attempt > 0)
      sys.fail(
          fmt::format("step {}: at run.dt = {:g} a body's flight after a collision ({:.4g} D) "
                      "is more than half the neighbour-list skin (run.skin = {:g}); use a "
                      "smaller run.dt or a larger run.skin",
                      sys.current_step() + 1, scene.dt, reach, scene.skin));
    ++record_.rebuilt_in_step;
    rebuild(sys);  // the same bounds as before the rebuild: checked then
  }
}

void ExactStep::tally(System &sys, const DetectionStats &detected, const ExactStats &stats) {
  IntervalTotals &t = sys.interval();
  t.steps += 1;
  t.collisions += stats.collisions;
  t.virial += stats.virial;
  t.narrow_phase_tests += detected.narrow_phase_tests;
  // The exact method's clusters are counted in summary.json's `exact` block only: steps taken in
  // one queue form none, so they are not the midpoint method's multi-contact clusters.
  t.contacts += stats.candidates;
  t.max_depth = std::max(t.max_depth, detected.max_depth);
  ++record_.steps;
  record_.totals += stats;
}

// Collective: the exact method's work since this process started, summed over ranks (the
// largest cluster: the largest on any rank): totals and per step. Collisions and clusters are
// counted once; the work (events, searches) of a cluster across ranks is counted by every rank
// that solved it.
void ExactStep::summarize(Communicator &comm, nlohmann::json &summary) const {
  ExactRecord r = record_;
  ExactStats &t = r.totals;
  for (long long *v :
       {&t.candidates, &t.apart, &t.clusters, &t.collisions, &t.events, &t.searches,
        &t.repredictions, &t.root_iterations, &t.unconverged, &t.regrown, &t.fallbacks, &t.grazes,
        &t.queued, &t.extra_pairs, &t.spares, &t.kept_apart})
    *v = comm.sum("summary", *v);
  t.largest_cluster = static_cast<long long>(
      comm.max("summary", {static_cast<double>(record_.totals.largest_cluster)})[0]);
  const double steps = r.steps > 0 ? static_cast<double>(r.steps) : 1.0;
  const auto per_step = [&](long long v) { return static_cast<double>(v) / steps; };
  summary["exact"] = {{"steps", r.steps},
                      {"collisions", t.collisions},
                      {"events", t.events},
                      {"searches", t.searches},
                      {"repredictions", t.repredictions},
                      {"root_iterations", t.root_iterations},
                      {"unconverged_searches", t.unconverged},
                      {"candidates", t.candidates},
                      {"apart", t.apart},
                      {"clusters", t.clusters},
                      {"largest_cluster", t.largest_cluster},
                      {"regrown", t.regrown},
                      {"fallbacks", t.fallbacks},
                      {"grazes", t.grazes},
                      {"queued_steps", t.queued},
                      {"extra_pairs", t.extra_pairs},
                      {"spare_pairs", t.spares},
                      {"kept_apart", t.kept_apart},
                      {"rebuilt_in_step", r.rebuilt_in_step},
                      {"list_extensions", comm.sum("summary", extension_.extensions)},
                      {"collisions_per_step", per_step(t.collisions)},
                      {"events_per_step", per_step(t.events)},
                      {"repredictions_per_step", per_step(t.repredictions)},
                      {"root_iterations_per_step", per_step(t.root_iterations)},
                      {"root_iterations_per_search",
                       t.searches > 0 ? static_cast<double>(t.root_iterations) / t.searches : 0.0}};
  summary["spanning_clusters"] = {{"exchanges", comm.sum("summary", r.exchanges)},
                                  {"resolved", comm.sum("summary", r.resolved)},
                                  {"from_results", comm.sum("summary", r.from_results)}};
}

void ExactStep::print_results(const nlohmann::json &summary) const {
  const nlohmann::json &x = summary["exact"];
  const long long queued = x["queued_steps"].get<long long>();
  fmt::print(
      "  exact collisions         {:.4g} per step; {:.4g} searches ({:.3g} gap evaluations "
      "each), {:.4g} re-predictions per step ({:.4g} more kept apart by their proofs); {}; "
      "fallbacks {}\n",
      x["collisions_per_step"].get<double>(),
      x["searches"].get<double>() / std::max(1.0, x["steps"].get<double>()),
      x["root_iterations_per_search"].get<double>(), x["repredictions_per_step"].get<double>(),
      x["kept_apart"].get<double>() / std::max(1.0, x["steps"].get<double>()),
      queued == x["steps"].get<long long>()
          ? std::string("events in one queue")
          : fmt::format("largest cluster {}", x["largest_cluster"].get<long long>()),
      x["fallbacks"].get<long long>());
}

}  // namespace hardrod
