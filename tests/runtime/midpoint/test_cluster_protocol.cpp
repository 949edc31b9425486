// The spanning-cluster protocol (runtime/midpoint/cluster_protocol.hpp) on synthetic records,
// without MPI: the wire format round trip, the clusters found in merged records against a
// brute-force connected components, their canonical order and completeness, and the scratch
// problem a rank resolves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "runtime/midpoint/cluster_protocol.hpp"

namespace hardrod {
namespace {

ClusterRecords::Body body(std::int64_t id, std::uint32_t degree, double seed) {
  ClusterRecords::Body b;
  b.id = id;
  b.degree = degree;
  for (int k = 0; k < 6; ++k) b.motion[k] = seed + 0.125 * k;
  return b;
}

Contact contact(std::int64_t a, std::int64_t b, double seed) {
  Contact c;
  c.id_i = std::min(a, b);
  c.id_j = std::max(a, b);
  c.normal = {seed, seed + 1.0, seed + 2.0};
  c.arm_i = {seed + 3.0, seed + 4.0, seed + 5.0};
  c.arm_j = {seed + 6.0, seed + 7.0, seed + 8.0};
  c.separation = {seed + 9.0, seed + 10.0, seed + 11.0};
  c.depth = seed + 12.0;
  c.inverse_mass = seed + 13.0;
  c.impulse = seed + 14.0;
  return c;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

bool same_bits(const Vec3 &a, const Vec3 &b) {
  return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}

TEST(ClusterProtocol, RecordsSurviveTheWire) {
  const std::vector<ClusterRecords::Body> bodies = {body(7, 2, 0.1), body(3, kDegreeUnknown, -0.7),
                                                    body(11, 1, 1e-300)};
  const std::vector<Contact> contacts = {contact(3, 7, 0.5), contact(7, 11, -2.25)};
  std::vector<const Contact *> pointers = {&contacts[0], &contacts[1]};
  std::vector<char> buf;
  pack_cluster(buf, bodies.data(), 2, pointers.data(), 1, Wire::kRecord);  // two clusters
  pack_cluster(buf, bodies.data() + 2, 1, pointers.data() + 1, 1, Wire::kRecord);
  ClusterRecords got;
  unpack_clusters(buf, got, Wire::kRecord);
  ASSERT_EQ(got.bodies.size(), bodies.size());
  ASSERT_EQ(got.contacts.size(), contacts.size());
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    EXPECT_EQ(got.bodies[b].id, bodies[b].id);
    EXPECT_EQ(got.bodies[b].degree, bodies[b].degree);
    for (int k = 0; k < 6; ++k)
      EXPECT_TRUE(same_bits(got.bodies[b].motion[k], bodies[b].motion[k]));
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Contact &a = got.contacts[c], &e = contacts[c];
    EXPECT_EQ(a.id_i, e.id_i);
    EXPECT_EQ(a.id_j, e.id_j);
    EXPECT_TRUE(same_bits(a.normal, e.normal));
    EXPECT_TRUE(same_bits(a.arm_i, e.arm_i));
    EXPECT_TRUE(same_bits(a.arm_j, e.arm_j));
    EXPECT_TRUE(same_bits(a.separation, e.separation));
    EXPECT_TRUE(same_bits(a.depth, e.depth));
    EXPECT_TRUE(same_bits(a.inverse_mass, e.inverse_mass));
    EXPECT_TRUE(same_bits(a.impulse, e.impulse));
  }
}

TEST(ClusterProtocol, ResultsCarryVelocitiesAndImpulsesOnly) {
  const std::vector<ClusterRecords::Body> bodies = {body(4, 3, 0.3)};
  const Contact c = contact(4, 9, 1.5);
  const Contact *pointer = &c;
  std::vector<char> records, results;
  pack_cluster(records, bodies.data(), 1, &pointer, 1, Wire::kRecord);
  pack_cluster(results, bodies.data(), 1, &pointer, 1, Wire::kResults);
  // Two counts, a body's id and six doubles, a contact's two ids and its impulse.
  EXPECT_EQ(results.size(),
            2 * sizeof(std::int32_t) + 3 * sizeof(std::int64_t) + 7 * sizeof(double));
  EXPECT_LT(results.size(), records.size());
  ClusterRecords got;
  unpack_clusters(results, got, Wire::kResults);
  ASSERT_EQ(got.bodies.size(), 1u);
  ASSERT_EQ(got.contacts.size(), 1u);
  EXPECT_EQ(got.bodies[0].degree, kDegreeUnknown);
  EXPECT_TRUE(same_bits(got.bodies[0].motion[5], bodies[0].motion[5]));
  EXPECT_EQ(got.contacts[0].id_j, 9);
  EXPECT_TRUE(same_bits(got.contacts[0].impulse, c.impulse));
  EXPECT_EQ(got.contacts[0].depth, 0.0);  // not sent
}

// Synthetic step: bodies with random ids, random contacts between them; "ranks" each see a
// random part of the contacts (with their bodies' degrees known for the bodies they own),
// and all their records merged must give the true clusters.
struct Synthetic {
  std::vector<std::int64_t> ids;
  std::vector<std::pair<std::int64_t, std::int64_t>> pairs;  // canonical, unique
  std::map<std::int64_t, std::uint32_t> degree;
};

Synthetic make_synthetic(std::mt19937_64 &rng, int bodies, int contacts) {
  Synthetic s;
  std::set<std::int64_t> ids;
  while (static_cast<int>(ids.size()) < bodies)
    ids.insert(static_cast<std::int64_t>(rng() % 10000));
  s.ids.assign(ids.begin(), ids.end());
  std::set<std::pair<std::int64_t, std::int64_t>> pairs;
  while (static_cast<int>(pairs.size()) < contacts) {
    const std::int64_t a = s.ids[rng() % s.ids.size()], b = s.ids[rng() % s.ids.size()];
    if (a != b) pairs.insert({std::min(a, b), std::max(a, b)});
  }
  s.pairs.assign(pairs.begin(), pairs.end());
  for (const auto &[a, b] : s.pairs) ++s.degree[a], ++s.degree[b];
  return s;
}

// Connected components by repeated relaxation: label = the smallest id reachable.
std::map<std::int64_t, std::int64_t> brute_force_labels(const Synthetic &s) {
  std::map<std::int64_t, std::int64_t> label;
  for (const auto &[a, b] : s.pairs) label[a] = a, label[b] = b;
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto &[a, b] : s.pairs) {
      const std::int64_t m = std::min(label[a], label[b]);
      if (label[a] != m || label[b] != m) changed = true;
      label[a] = label[b] = m;
    }
  }
  return label;
}

// Every contact seen by the owners of its bodies (id % ranks) and by some other senders
// (duplicates); each sender tells the degree of the bodies it owns when `degrees`.
ClusterRecords merged_records(const Synthetic &s, std::mt19937_64 &rng, int ranks, bool degrees) {
  std::vector<char> wire;
  for (int r = 0; r < ranks; ++r) {
    std::vector<ClusterRecords::Body> bodies;
    std::vector<Contact> contacts;
    for (std::size_t k = 0; k < s.pairs.size(); ++k) {
      // An owner sees every contact of its bodies (as the pair list keeps them); others some.
      const bool owns = s.pairs[k].first % ranks == r || s.pairs[k].second % ranks == r;
      const bool mine = owns || rng() % 3 == 0;
      if (!mine) continue;
      contacts.push_back(contact(s.pairs[k].first, s.pairs[k].second, static_cast<double>(k)));
      for (std::int64_t id : {s.pairs[k].first, s.pairs[k].second}) {
        const bool owner = id % ranks == r && degrees;
        bodies.push_back(body(id, owner ? s.degree.at(id) : kDegreeUnknown, 0.5 * id));
      }
    }
    std::vector<const Contact *> pointers;
    for (const Contact &c : contacts) pointers.push_back(&c);
    pack_cluster(wire, bodies.data(), bodies.size(), pointers.data(), pointers.size(),
                 Wire::kRecord);
  }
  ClusterRecords records;
  unpack_clusters(wire, records, Wire::kRecord);
  records.tidy();
  return records;
}

TEST(ClusterProtocol, ClustersOfMergedRecordsAreTheConnectedComponents) {
  std::mt19937_64 rng(17);
  for (int trial = 0; trial < 50; ++trial) {
    const Synthetic s = make_synthetic(rng, 5 + trial, 3 + trial % 17 + trial / 2);
    const int ranks = 1 + trial % 4;
    const ClusterRecords records = merged_records(s, rng, ranks, true);
    // tidy: bodies by id, unique; contacts canonical, unique; i and j point at the bodies.
    ASSERT_EQ(records.contacts.size(), s.pairs.size());
    for (std::size_t b = 1; b < records.bodies.size(); ++b)
      ASSERT_LT(records.bodies[b - 1].id, records.bodies[b].id);
    for (std::size_t k = 0; k < records.contacts.size(); ++k) {
      const Contact &c = records.contacts[k];
      ASSERT_EQ(std::make_pair(c.id_i, c.id_j), s.pairs[k]);
      ASSERT_EQ(records.bodies[c.i].id, c.id_i);
      ASSERT_EQ(records.bodies[c.j].id, c.id_j);
      // The owner's count survived the merge with the other ranks' unknowns.
      ASSERT_EQ(records.bodies[c.i].degree, s.degree.at(c.id_i));
    }

    const RecordClusters rc = cluster_records(records);
    const auto label = brute_force_labels(s);
    std::set<std::int64_t> components;
    for (const auto &[id, l] : label) components.insert(l);
    ASSERT_EQ(rc.count(), components.size());
    std::int64_t previous_lowest = -1;
    std::size_t listed = 0;
    for (std::size_t c = 0; c < rc.count(); ++c) {
      const Contact &first = records.contacts[rc.contact(c, 0)];
      const std::int64_t l = label.at(first.id_i);
      // Canonical inside, one component each, components in order of their lowest id.
      EXPECT_GT(l, previous_lowest);
      previous_lowest = l;
      for (std::size_t k = 0; k < rc.size(c); ++k) {
        const Contact &ct = records.contacts[rc.contact(c, k)];
        EXPECT_EQ(label.at(ct.id_i), l);
        EXPECT_EQ(rc.cluster_of_body[ct.i], c);
        EXPECT_EQ(rc.cluster_of_body[ct.j], c);
        if (k > 0) {
          EXPECT_TRUE(canonical_less(records.contacts[rc.contact(c, k - 1)], ct));
        }
      }
      std::size_t in_component = 0;
      for (const auto &[a, b] : s.pairs) in_component += label.at(a) == l;
      EXPECT_EQ(rc.size(c), in_component);
      listed += rc.size(c);
      EXPECT_TRUE(rc.complete[c]);
    }
    EXPECT_EQ(listed, s.pairs.size());
  }
}

TEST(ClusterProtocol, AClusterIsIncompleteWithoutEveryOwnersCount) {
  std::mt19937_64 rng(5);
  const Synthetic s = make_synthetic(rng, 30, 25);
  ClusterRecords records = merged_records(s, rng, 2, true);
  // One body's owner did not report (unknown), another's count disagrees (a contact missing).
  const std::int64_t silent = records.contacts.front().id_i;
  const std::int64_t short_one = records.contacts.back().id_j;
  records.bodies[records.at(silent)].degree = kDegreeUnknown;
  records.bodies[records.at(short_one)].degree += 1;
  const RecordClusters rc = cluster_records(records);
  for (std::size_t c = 0; c < rc.count(); ++c) {
    bool has_bad = false;
    for (std::size_t k = 0; k < rc.size(c); ++k) {
      const Contact &ct = records.contacts[rc.contact(c, k)];
      for (std::int64_t id : {ct.id_i, ct.id_j})
        has_bad = has_bad || id == silent || id == short_one;
    }
    EXPECT_EQ(rc.complete[c] != 0, !has_bad) << "cluster " << c;
  }
}

TEST(ClusterProtocol, NoRecordsNoClusters) {
  ClusterRecords records;
  records.tidy();
  const RecordClusters rc = cluster_records(records);
  EXPECT_EQ(rc.count(), 0u);
  Particles work;
  std::vector<Contact> solved;
  std::vector<std::uint32_t> slot;
  EXPECT_EQ(scratch_problem(records, rc, {}, {}, work, solved, slot), 0u);
  EXPECT_EQ(work.size(), 0u);
  EXPECT_TRUE(solved.empty());
}

TEST(ClusterProtocol, ScratchProblemPutsOwnedBodiesFirstInIdOrder) {
  std::mt19937_64 rng(11);
  const Synthetic s = make_synthetic(rng, 40, 30);
  const ClusterRecords records = merged_records(s, rng, 3, true);
  const RecordClusters rc = cluster_records(records);
  std::vector<char> take(rc.count(), 0), owned(records.bodies.size(), 0);
  for (std::size_t c = 0; c < rc.count(); c += 2) take[c] = 1;
  for (std::size_t b = 0; b < owned.size(); ++b) owned[b] = records.bodies[b].id % 3 == 0;
  Particles work;
  std::vector<Contact> solved;
  std::vector<std::uint32_t> slot;
  const std::size_t counted = scratch_problem(records, rc, take, owned, work, solved, slot);

  std::size_t expected_bodies = 0, expected_owned = 0, expected_contacts = 0;
  for (std::size_t b = 0; b < records.bodies.size(); ++b) {
    const std::uint32_t c = rc.cluster_of_body[b];
    const bool taken = c != kDegreeUnknown && take[c];
    ASSERT_EQ(slot[b] != kDegreeUnknown, taken);
    if (!taken) continue;
    ++expected_bodies;
    expected_owned += owned[b] != 0;
    EXPECT_EQ(slot[b] < counted, owned[b] != 0);
    EXPECT_EQ(work.id[slot[b]], records.bodies[b].id);
    EXPECT_EQ(work.vx[slot[b]], records.bodies[b].motion[0]);
    EXPECT_EQ(work.wz[slot[b]], records.bodies[b].motion[5]);
  }
  for (std::size_t c = 0; c < rc.count(); ++c) expected_contacts += take[c] ? rc.size(c) : 0;
  EXPECT_EQ(work.size(), expected_bodies);
  EXPECT_EQ(counted, expected_owned);
  ASSERT_EQ(solved.size(), expected_contacts);
  for (std::size_t k = 0; k < solved.size(); ++k) {
    EXPECT_EQ(work.id[solved[k].i], solved[k].id_i);
    EXPECT_EQ(work.id[solved[k].j], solved[k].id_j);
    if (k > 0) {
      EXPECT_TRUE(canonical_less(solved[k - 1], solved[k]));
    }
  }
  // Each group in id order.
  for (std::size_t k = 1; k < work.size(); ++k)
    if (k != counted) {
      EXPECT_LT(work.id[k - 1], work.id[k]);
    }
}

}  // namespace
}  // namespace hardrod
