// The exact method's collisions within one time step (run.method = "exact", docs/physics.md
// section 3): every collision at its exact time on the bodies' free-flight trajectories, in
// time order within each cluster of bodies that can interact in the step, with the elastic,
// frictionless impulse at the touching configuration.
//
// Inputs: the bodies at the step's start, their motion bounds already grown by the step's free
// flight (grow_bounds, free_flight.hpp); the pair list, its slacks renewed for the start by the
// detection with `ahead` (contact_detection.hpp); and the candidates that detection found: the
// listed pairs whose gap is below the two bodies' flights in the step.
//
// Clusters: the candidates joined by shared bodies. Within a cluster an event-driven pass runs
// from t = 0 to dt: each candidate gets its first contact time (first_contact,
// contact_time.hpp); the earliest event is taken (ties by ids), the two bodies get the impulse
// and every listed pair of either body inside the cluster is predicted again from then. A
// candidate the detection marked `apart` (its free flights keep it apart all step) is not
// searched until one of its bodies changes velocity, and a cluster of such candidates only is
// not visited: nothing in it can happen (the same trajectory as searching them). A body
// whose new velocity carries it further than its free flight would have (its "overrun") may
// reach a body outside its cluster: each such listed pair is checked against its slack with
// the bodies' real bounds, and where it could touch the two clusters are joined and solved
// again from the step's start, until no cluster can reach another. Every cluster's result
// depends only on its bodies, so the trajectory does not depend on the thread count or on the
// order clusters are processed in.
//
// A cluster that takes more than events_per_body events per body in one step (an inelastic
// collapse cannot happen with elastic impulses, but a jammed cluster can chatter) has its
// touching pairs solved together by the simultaneous solver (contact_resolution.hpp) at that
// time, once; this is counted (ExactStats::fallbacks).
//
// One queue (ExactSettings::one_queue, what one thread on one rank uses): the same events, no
// clusters. The whole step's events are taken from one queue by time (ties by ids) on one
// thread; a body whose velocity changes is predicted again against its candidate partners
// (spares too), and, where its new velocity could carry it beyond its free flight's bound by
// more than the overrun allowance, its other listed pairs that its overrun could bring to
// touch join them (exact_queue.cpp). A prediction depends only on the two bodies' flights, so
// the end states are the clusters' to the bit (tests/kernels/test_exact_collisions.cpp
// compares them). A step with a body in more than twice events_per_body events is solved by
// clusters instead, whose fallback it is; the clusters leave the spares out.
//
// Reads the bodies (their state at the step's start is never written here); writes the
// `flown` list: the end states of the bodies whose velocity changed, which land_flown writes
// over the free flight's (fly_step). Threads take whole clusters; the one queue runs on one.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/contact.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/exact/contact_time.hpp"
#include "kernels/exact/step_candidates.hpp"
#include "kernels/exact_sum.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

struct ExactSettings {
  ContactTimeSettings contact;  // the root search's tolerance (1e-10 D) and iteration cap
  long events_per_body = 100;   // events a cluster may take per body in one step
  SolverSettings solver;        // the fallback's simultaneous solver
  // collide_exactly: the step's events in one queue rather than by cluster (the same bits).
  bool one_queue = false;
  // The one queue's overrun allowance (D): how far beyond its free flight's bound a body may
  // end the step before its listed pairs are checked against its overrun. The detection must
  // have found the pairs within it (StepAhead::allowance, Candidate::spare). 0: every overrun.
  double overrun_allowance = 0.0;
};

// One step's counts: collisions, virial, clusters and fallbacks of the final partition; the
// work (events, searches, iterations, grazes) of every pass, including those a join discarded.
struct ExactStats {
  long long candidates = 0;       // listed pairs that could touch in the step
  long long apart = 0;            // of those, kept apart by their free flights (Candidate::apart)
  long long spares = 0;           // pairs within the overrun allowance only (Candidate::spare)
  long long clusters = 0;         // clusters of candidates
  long long largest_cluster = 0;  // bodies in the largest
  long long collisions = 0;       // impulses given
  long long events = 0;           // events taken from the queues (valid, not stale)
  long long searches = 0;         // first-contact searches
  long long repredictions = 0;    // of those, after a velocity changed within the step
  long long root_iterations = 0;  // gap evaluations of the searches
  long long unconverged = 0;      // searches that used up their iterations (resumed later)
  long long regrown = 0;          // joins of clusters that a body's overrun could reach
  long long fallbacks = 0;        // clusters past the event cap (simultaneous solver)
  long long grazes = 0;           // contacts found closing that the impulse saw receding
  long long queued = 0;           // steps whose events ran in one queue (ExactSettings::one_queue)
  long long extra_pairs = 0;      // the queue's pairs a body's overrun could bring to touch
  long long kept_apart = 0;       // the queue's searches again left out: the pair's proof held
  ExactSum virial;                // sum of J n . (x_i - x_j) at the touching configuration

  // Sums, and the larger largest_cluster.
  ExactStats &operator+=(const ExactStats &other);
};

// A body whose velocity changed in the step: its state at the step's end, how much further
// it may have moved than its free flight's bound (grow_bounds) allowed, and the collisions in
// which it was the lower-id body with their virial (so that each is counted once, by the
// owner of that body, on any number of ranks).
struct FlownBody {
  std::uint32_t body = 0;
  Vec3 x, e, v, w;
  double overrun = 0.0;
  long long collisions = 0;
  ExactSum virial;
};

// Two bodies (indices) whose clusters are solved as one.
using BodyPair = std::pair<std::uint32_t, std::uint32_t>;

// Scratch kept between steps (per-body arrays over the list's bodies).
struct ExactScratch {
  std::vector<std::uint32_t> parent;  // union-find over bodies; UINT32_MAX: not involved
  std::vector<std::uint32_t>
      label;                    // the cluster (its index) of an involved body; the queue's slot
  std::vector<double> overrun;  // of a flown body, else 0
  std::vector<std::uint32_t> involved;  // the bodies of a step's candidates and joins
  std::vector<std::uint64_t> involved_bits;
  std::vector<std::uint32_t> first_edge;  // the one queue's: a body's first partner (kNone: none)
};

ExactStats collide_exactly(const Particles &p, const Box &box, const Shape &shape,
                           const NeighborList &list, const std::vector<Candidate> &candidates,
                           double dt, const ExactSettings &settings, ExactScratch &scratch,
                           std::vector<FlownBody> &flown);

// For several ranks (runtime/exact_ranks.cpp), where the joins of clusters are agreed between
// ranks: the clusters of the candidates and `joins` solved once each, without looking for
// overruns that reach other clusters (overrun_reaches does, for the caller). The same bits
// per cluster as collide_exactly's for the same cluster.
ExactStats collide_once(const Particles &p, const Box &box, const Shape &shape,
                        const NeighborList &list, const std::vector<Candidate> &candidates,
                        const std::vector<BodyPair> &joins, double dt,
                        const ExactSettings &settings, ExactScratch &scratch,
                        std::vector<FlownBody> &flown);

// The listed pairs (each once, lower index first) whose bodies lie in different clusters
// (`cluster`, a label by body; -1 for none) and could have touched in the step given the flown
// bodies' overruns: the test collide_exactly uses between its clusters. `overrun` is scratch (by
// body, zeros on entry and on return). With `from` (by body), only the pairs of the flown bodies
// it marks are checked (every flown body's overrun still counts for its partners).
std::vector<BodyPair> overrun_reaches(const Particles &p, const Box &box, const Shape &shape,
                                      const NeighborList &list, const std::vector<FlownBody> &flown,
                                      const std::vector<std::int64_t> &cluster,
                                      std::vector<double> &overrun,
                                      const std::vector<char> *from = nullptr);

// The flown bodies' end states written over their free flight's, and their motion bounds
// grown by their overrun (the caller refreshes their motion constants). Without `turns`
// (spheres) axis and spin are left as they are: the exact method never changes them
// (start_flight, exact_events.hpp), and its flights do not carry them.
void land_flown(Particles &p, const std::vector<FlownBody> &flown, bool turns);

}  // namespace hardrod
