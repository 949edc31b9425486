// Phase 5b of the midpoint method's step (runtime/midpoint/midpoint_step.hpp): the contact clusters
// with a body that other ranks hold (shadows, or owned bodies with shadow copies), resolved across
// ranks. Every rank detects exactly the contacts of the bodies it owns (the pair list keeps the
// pairs with an owned body), so a cluster's contacts are the union of its owners' records. In one
// exchange each rank sends, for each such cluster it sees, its contacts, the velocities of the
// bodies and the contact counts of the bodies it owns, to every owner and holder of those bodies. A
// rank merges what it gets with its own; a merged cluster is complete when every body's count
// is its owner's, and then the rank resolves it itself: the same contacts in the same order
// with the same velocities give the same bits on every rank, so no results travel. With two
// ranks every rank that holds a body of a cluster gets all of it this way. With more, a
// cluster can reach a rank only in part; a second exchange then sends every resolved
// cluster's velocities and impulses to the ranks that hold its bodies. An owned body left in
// an unresolved cluster is an error, reported collectively at the next step. The records and
// their wire format are in runtime/midpoint/cluster_protocol.hpp; the solver in kernels/.
#include <algorithm>

#include "runtime/midpoint/midpoint_step.hpp"

namespace hardrod {

namespace {

constexpr std::size_t kNone = System::kNotAdvanced;

}  // namespace

// Returns the solver's statistics of the clusters counted here (those whose first contact's
// lower-id body this rank owns).
ResolutionStats MidpointStep::resolve_across_ranks(System &sys, const ContactClusters &cc,
                                                   const std::vector<char> &local) {
  ClusterRecords records = exchange_records(sys, cc, local);
  const RecordClusters rc = cluster_records(records);
  // Where each record body is here: its local index among the bodies this rank advances.
  std::vector<std::size_t> where(records.bodies.size());
  std::vector<char> owned(records.bodies.size());
  for (std::size_t b = 0; b < records.bodies.size(); ++b) {
    where[b] = sys.advanced_index(records.bodies[b].id);
    owned[b] = where[b] < sys.owned_count();
  }
  const std::vector<char> take = clusters_to_resolve(records, rc, where, sys.owned_count());
  std::vector<Contact> solved;
  std::vector<std::uint32_t> slot;
  const std::size_t counted =
      scratch_problem(records, rc, take, owned, spanning_bodies_, solved, slot);
  const ResolutionStats stats = resolve_clusters(spanning_bodies_, sys.scene().shape, solved,
                                                 find_clusters(solved), {}, solver_, counted);
  note_spanning(records, rc, take, owned);

  // The results: velocities of the bodies held here, impulses of this rank's contacts.
  Particles &p = sys.particles();
  settled_.resize(p.size(), 0);
  const std::size_t first_settled = shared_in_.size();
  for (std::size_t b = 0; b < records.bodies.size(); ++b) {
    if (slot[b] == kDegreeUnknown) continue;
    double m[6];
    read_motion(spanning_bodies_, slot[b], m);
    settle_body(p, where[b], m);
  }
  for (const Contact &ct : solved) set_impulse(ct);
  if (sys.comm().size() > 2 || results_exchange_)
    exchange_results(sys, records, rc, take, slot, solved);
  note_unresolved(sys, cc, local);
  for (std::size_t k = first_settled; k < shared_in_.size(); ++k) settled_[shared_in_[k]] = 0;
  return stats;
}

// The contacts exchange: this rank's records of every cluster with a body held elsewhere, to
// the owners and holders of its bodies; returns them merged with what the partners sent.
ClusterRecords MidpointStep::exchange_records(System &sys, const ContactClusters &cc,
                                              const std::vector<char> &local) {
  const auto &partners = sys.domain().partners();
  const Particles &p = sys.particles();
  ClusterRecords records;
  std::vector<int> targets;
  std::vector<std::vector<char>> &out = spanning_out_;
  out.resize(partners.size());
  for (auto &o : out) o.clear();
  std::vector<const Contact *> mine;
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (local[c]) continue;
    const std::size_t first_body = records.bodies.size();
    mine.clear();
    targets.clear();
    for (std::size_t k = cc.start[c]; k < cc.start[c + 1]; ++k) {
      const Contact &ct = contacts_[cc.order[k]];
      mine.push_back(&ct);
      records.contacts.push_back(ct);
      for (std::uint32_t i : {ct.i, ct.j}) {
        ClusterRecords::Body b;
        b.id = p.id[i];
        if (std::any_of(records.bodies.begin() + static_cast<long>(first_body),
                        records.bodies.end(),
                        [&](const ClusterRecords::Body &o) { return o.id == b.id; }))
          continue;
        b.degree = i < sys.owned_count() ? cc.degree[cc.find(i)] : kDegreeUnknown;
        read_motion(p, i, b.motion);
        records.bodies.push_back(b);
        sys.add_targets(b.id, targets);
      }
    }
    sort_unique(targets);
    for (int r : targets)
      pack_cluster(out[sys.domain().partner_slot(r)], records.bodies.data() + first_body,
                   records.bodies.size() - first_body, mine.data(), mine.size(), Wire::kRecord);
  }
  for (const auto &buf : sys.comm().exchange("contacts", partners, out))
    unpack_clusters(buf, records, Wire::kRecord);
  records.tidy();
  return records;
}

// The complete clusters with a body this rank advances (with the results exchange for
// tests: only those this rank counts).
std::vector<char> MidpointStep::clusters_to_resolve(const ClusterRecords &records,
                                                    const RecordClusters &rc,
                                                    const std::vector<std::size_t> &where,
                                                    std::size_t owned) const {
  std::vector<char> take(rc.count(), 0);
  for (std::size_t b = 0; b < records.bodies.size(); ++b)
    if (where[b] != kNone && rc.cluster_of_body[b] != kDegreeUnknown)
      take[rc.cluster_of_body[b]] = 1;  // held here
  for (std::size_t c = 0; c < rc.count(); ++c) {
    take[c] = take[c] && rc.complete[c];
    if (results_exchange_) take[c] = take[c] && where[records.contacts[rc.contact(c, 0)].i] < owned;
  }
  return take;
}

void MidpointStep::note_spanning(const ClusterRecords &records, const RecordClusters &rc,
                                 const std::vector<char> &take, const std::vector<char> &owned) {
  ++spanning_.exchanges;
  for (std::size_t c = 0; c < rc.count(); ++c) {
    if (!take[c]) continue;
    ++spanning_.resolved;
    spanning_.multi_contact += rc.size(c) > 1;
    bool remote = false;
    for (std::size_t k = 0; k < rc.size(c); ++k) {
      const Contact &ct = records.contacts[rc.contact(c, k)];
      remote = remote || (!owned[ct.i] && !owned[ct.j]);
    }
    spanning_.put_together += remote;
  }
}

// Body i's velocities from a resolution (once per step; kNone: not held here). Its motion
// constants are then due (midpoint).
void MidpointStep::settle_body(Particles &p, std::size_t i, const double (&m)[6]) {
  if (i == kNone || settled_[i]) return;
  write_motion(p, i, m);
  shared_in_.push_back(static_cast<std::uint32_t>(i));
  settled_[i] = 1;
}

// The impulse of this rank's contact with the ids of `solved`, if it has one.
void MidpointStep::set_impulse(const Contact &solved) {
  const auto it = std::lower_bound(contacts_.begin(), contacts_.end(), solved, canonical_less);
  if (it != contacts_.end() && it->id_i == solved.id_i && it->id_j == solved.id_j)
    it->impulse = solved.impulse;
}

// The results exchange, for clusters that reached a rank only in part: the velocities and
// impulses of every cluster resolved here, to the owners and holders of its bodies that this
// rank knows (duplicates carry the same bits).
void MidpointStep::exchange_results(System &sys, const ClusterRecords &records,
                                    const RecordClusters &rc, const std::vector<char> &take,
                                    const std::vector<std::uint32_t> &slot,
                                    const std::vector<Contact> &solved) {
  const Particles &work = spanning_bodies_;
  std::vector<std::vector<char>> &results = spanning_out_;
  for (auto &o : results) o.clear();
  std::vector<std::vector<std::uint32_t>> members(rc.count());
  for (std::size_t b = 0; b < slot.size(); ++b)
    if (slot[b] != kDegreeUnknown) members[rc.cluster_of_body[b]].push_back(slot[b]);
  std::vector<ClusterRecords::Body> done;
  std::vector<const Contact *> impulses;
  std::vector<int> targets;
  for (std::size_t c = 0; c < rc.count(); ++c) {
    if (!take[c]) continue;
    done.clear();
    impulses.clear();
    targets.clear();
    for (std::uint32_t k : members[c]) {
      ClusterRecords::Body body;
      body.id = work.id[k];
      read_motion(work, k, body.motion);
      done.push_back(body);
      sys.add_targets(body.id, targets);
    }
    for (std::size_t k = 0; k < rc.size(c); ++k) {  // solved holds them in the same order
      const Contact &probe = records.contacts[rc.contact(c, k)];
      impulses.push_back(&*std::lower_bound(solved.begin(), solved.end(), probe, canonical_less));
    }
    sort_unique(targets);
    for (int r : targets)
      pack_cluster(results[sys.domain().partner_slot(r)], done.data(), done.size(), impulses.data(),
                   impulses.size(), Wire::kResults);
  }
  for (const auto &in : sys.comm().exchange("results", sys.domain().partners(), results)) {
    ClusterRecords got;
    unpack_clusters(in, got, Wire::kResults);
    for (const ClusterRecords::Body &b : got.bodies) {
      const std::size_t i = sys.advanced_index(b.id);
      spanning_.from_results += i != kNone && !settled_[i];
      settle_body(sys.particles(), i, b.motion);
    }
    for (const Contact &ct : got.contacts) set_impulse(ct);
  }
}

// An owned body in a cluster that no rank resolved for it: an error for the next agreement.
void MidpointStep::note_unresolved(System &sys, const ContactClusters &cc,
                                   const std::vector<char> &local) const {
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (local[c]) continue;
    for (std::size_t k = cc.start[c]; k < cc.start[c + 1]; ++k) {
      const Contact &ct = contacts_[cc.order[k]];
      for (std::uint32_t i : {ct.i, ct.j})
        if (i < sys.owned_count() && !settled_[i])
          sys.note_unresolved(static_cast<double>(cc.start[c + 1] - cc.start[c]));
    }
  }
}

}  // namespace hardrod
