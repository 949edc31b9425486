// The spanning-cluster protocol's data, without MPI: what ranks tell each other of the
// contact clusters whose bodies live on several ranks (records and results), their wire
// format, and the clusters found in merged records. MidpointStep::resolve_across_ranks
// (runtime/midpoint/spanning_clusters.cpp) runs the exchanges; docs/physics.md section 7 gives the
// determinism it keeps. A contact or a velocity seen by two ranks carries the same bits on
// both (same bodies, same arithmetic), so duplicates are dropped by id. The grouping of
// contacts into clusters is the kernels' (find_clusters, kernels/contact_resolution.hpp).
// Not here: which ranks a record goes to, and the solver.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/contact.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/particles.hpp"
#include "runtime/body_wire.hpp"

namespace hardrod {

// What a rank knows in one step of the clusters that span ranks: bodies (velocities, and
// the contact count their owner detected) and contacts, from its own detection and from the
// records its partners sent.
struct ClusterRecords {
  struct Body {
    std::int64_t id = 0;
    std::uint32_t degree = kDegreeUnknown;  // from the owner
    double motion[6] = {};                  // v, w
  };
  std::vector<Body> bodies;       // by id after tidy()
  std::vector<Contact> contacts;  // canonical after tidy(); i and j index `bodies`

  // Sorts and drops duplicates, keeping a body's owner's count where any record has it,
  // and points every contact's i and j at its bodies. Every contact's bodies must be present.
  void tidy();
  // Position of body `id` (present after tidy()).
  std::uint32_t at(std::int64_t id) const;
};

// A body's v and w as one record's six doubles, and back.
void read_motion(const Particles &p, std::size_t i, double (&m)[6]);
void write_motion(Particles &p, std::size_t i, const double (&m)[6]);

// What a message carries of a cluster. A record (the contacts exchange): the bodies (id,
// owner's contact count or kDegreeUnknown, v, w) and the contacts (everything the solver
// reads, and the impulse: 0 before resolution). Results (the results exchange): the bodies'
// new velocities (id, v, w) and the contacts' impulses (ids, impulse).
enum class Wire { kRecord, kResults };

// Appends one cluster's `nb` bodies and `nc` contacts to `buf`.
void pack_cluster(std::vector<char> &buf, const ClusterRecords::Body *bodies, std::size_t nb,
                  const Contact *const *contacts, std::size_t nc, Wire wire);
// Appends every cluster in `buf` to `r` (untidy: call r.tidy()).
void unpack_clusters(const std::vector<char> &buf, ClusterRecords &r, Wire wire);

// The clusters of tidy records: contacts grouped by connected bodies (contact indices in
// canonical order, cluster by cluster; clusters ordered by their lowest body id), each
// complete when every body's owner's count is known and equals the contacts listed for it.
struct RecordClusters {
  ContactClusters groups;                      // find_clusters over the records' contacts
  std::vector<std::uint32_t> cluster_of_body;  // by record body; kDegreeUnknown: no contact
  std::vector<char> complete;                  // by cluster

  std::size_t count() const { return groups.count(); }
  std::size_t size(std::size_t c) const { return groups.start[c + 1] - groups.start[c]; }
  // The k-th contact (in canonical order) of cluster c, as an index into the records.
  std::uint32_t contact(std::size_t c, std::size_t k) const {
    return groups.order[groups.start[c] + k];
  }
};

RecordClusters cluster_records(const ClusterRecords &r);

// The scratch problem of the clusters with take[c] != 0: their bodies in `work` (velocities
// from the records; bodies with owned[b] first, each group in id order) and their contacts
// in canonical order, i and j pointing into `work`. slot[b] is record body b's place in
// `work` (kDegreeUnknown: not taken). Returns how many of `work`'s bodies are owned: the
// solver counts the clusters whose first contact's lower-id body is among them.
std::size_t scratch_problem(const ClusterRecords &r, const RecordClusters &rc,
                            const std::vector<char> &take, const std::vector<char> &owned,
                            Particles &work, std::vector<Contact> &solved,
                            std::vector<std::uint32_t> &slot);

}  // namespace hardrod
