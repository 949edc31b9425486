// The paper's method (run.method = "midpoint", docs/physics.md section 3): contacts found and
// resolved at the step's midpoint. Its phases of runtime/system.hpp:
//   1. first half: free flight to the midpoint (kernels/free_flight.hpp), with phase 2 in the
//      same pass when the pair list keeps watches (to_midpoint)
//   2. detect: the overlapping listed pairs (detect, kernels/contact_detection.hpp)
//   5. resolve: elastic impulses, (a) of the clusters this rank holds in full
//      (kernels/contact_resolution.hpp), (b) of those across ranks, with one exchange of
//      contact records and, on more than two ranks, one of results (resolve_across_ranks,
//      runtime/midpoint/spanning_clusters.cpp and cluster_protocol.hpp)
//   6. second half: free flight to the end of the step, in one pass with the next step's
//      phase 1 where nothing acts between them (second_half, to_midpoint(2))
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/contact.hpp"
#include "kernels/contact_detection.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/free_flight.hpp"
#include "runtime/midpoint/cluster_protocol.hpp"
#include "runtime/step_method.hpp"
#include "runtime/system.hpp"

namespace hardrod {

// Clusters with bodies on several ranks (MidpointStep::resolve_across_ranks), this rank's
// counts since it started: a diagnostic of the protocol, not restored by a restart.
struct SpanningRecord {
  long long exchanges = 0;      // steps with an exchange of contact records
  long long resolved = 0;       // clusters this rank resolved from merged records
  long long multi_contact = 0;  // of those, with more than one contact
  long long put_together = 0;   // of those, with a contact this rank did not detect
  long long from_results = 0;   // bodies set by another rank's results (more than two ranks)
};

class MidpointStep final : public StepMethod {
 public:
  MidpointStep(const Scene &scene, const ParallelOptions &parallel);

  void step(System &system) override;
  void finish(System &system, bool next_follows) override;
  void summarize(Communicator &comm, nlohmann::json &summary) const override;
  void print_parallel(const nlohmann::json &summary) const override;

  const SpanningRecord &spanning_record() const { return spanning_; }

 private:
  MidpointDetection to_midpoint(System &sys, int halves);        // 1 (and 2), or 6 and 1
  void midpoint(System &sys, const MidpointDetection &reached);  // 2-5
  DetectionStats detect(System &sys);                            // 2
  bool touches_boundary(System &sys) const;
  ResolutionStats resolve(System &sys, const Agreement &agreed, std::vector<char> &counted);  // 5
  ResolutionStats resolve_on_ranks(System &sys, const ContactClusters &clusters, bool exchange);
  void tally(System &sys, const DetectionStats &detected, const ResolutionStats &resolved,
             const std::vector<char> &counted) const;
  void second_half(System &sys);  // 6

  // 5b, spanning_clusters.cpp: the clusters with local[c] == 0 (a body other ranks hold),
  // put together from every owner's contacts and resolved. Collective over partners.
  ResolutionStats resolve_across_ranks(System &sys, const ContactClusters &clusters,
                                       const std::vector<char> &local);
  ClusterRecords exchange_records(System &sys, const ContactClusters &clusters,
                                  const std::vector<char> &local);
  std::vector<char> clusters_to_resolve(const ClusterRecords &records, const RecordClusters &rc,
                                        const std::vector<std::size_t> &where,
                                        std::size_t owned) const;
  void note_spanning(const ClusterRecords &records, const RecordClusters &rc,
                     const std::vector<char> &take, const std::vector<char> &owned);
  void exchange_results(System &sys, const ClusterRecords &records, const RecordClusters &rc,
                        const std::vector<char> &take, const std::vector<std::uint32_t> &slot,
                        const std::vector<Contact> &solved);
  void note_unresolved(System &sys, const ContactClusters &clusters,
                       const std::vector<char> &local) const;
  void settle_body(Particles &p, std::size_t i, const double (&motion)[6]);
  void set_impulse(const Contact &solved);

  SolverSettings solver_;
  bool results_exchange_ = false;  // ParallelOptions::results_exchange
  std::vector<Contact> contacts_;  // each step's
  // Phase 1 of the next step, done with this one's 6 (finish with next_follows).
  MidpointDetection reached_;
  bool at_midpoint_ = false;
  // Bodies whose velocities a step changed (their motion constants are then due): those
  // resolve_across_ranks set, and the scratch list of all of them.
  std::vector<std::uint32_t> shared_in_, changed_;
  SpanningRecord spanning_;
  // Scratch of resolve_across_ranks, kept between steps so that a step allocates nothing:
  // by local index, whether a body got its velocities this step (all 0 between calls); the
  // bodies of the clusters it resolves; its outgoing messages.
  std::vector<char> settled_;
  Particles spanning_bodies_;
  std::vector<std::vector<char>> spanning_out_;
};

}  // namespace hardrod
