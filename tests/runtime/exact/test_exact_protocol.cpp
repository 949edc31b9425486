// The exact method's clusters across ranks without MPI (runtime/exact/exact_protocol.hpp): pieces
// merged and their completeness, the wire format, the scratch problem and the results.
#include <gtest/gtest.h>

#include <cstring>

#include "runtime/exact/exact_protocol.hpp"

namespace hardrod {
namespace {

ExactPieces::Body body(std::int64_t id, std::uint32_t degree = kDegreeUnknown) {
  ExactPieces::Body b;
  b.id = id;
  b.degree = degree;
  for (std::size_t k = 0; k < kExactState; ++k) b.state[k] = 0.1 * static_cast<double>(id) + k;
  return b;
}

// Two ranks each own one end of a chain 1 - 2 - 3 (rank A owns 1, 2; rank B owns 3) with a
// join 3 - 7 (B owns 7); body 9 is alone.
struct Chain {
  std::vector<ExactPieces::Body> a_bodies{body(1, 1), body(2, 2), body(3)};
  std::vector<ExactPieces::Edge> a_edges{{1, 2, 1}, {2, 3, 1}};
  std::vector<ExactPieces::Body> b_bodies{body(2), body(3, 2), body(7, 1)};
  std::vector<ExactPieces::Edge> b_edges{{2, 3, 1}, {3, 7, 0}};
};

TEST(ExactProtocol, AClusterIsCompleteOnlyWithEveryOwnersPiece) {
  const Chain c;
  std::vector<char> a, b;
  pack_piece(a, c.a_bodies, c.a_edges);
  pack_piece(b, c.b_bodies, c.b_edges);
  ExactPieces only_a;
  unpack_pieces(a, only_a);
  only_a.tidy();
  const ExactClusters partial = exact_clusters(only_a);
  ASSERT_EQ(partial.count(), 1u);
  EXPECT_FALSE(partial.complete[0]);  // body 3's owner has not spoken

  ExactPieces both;
  unpack_pieces(b, both);  // in either order, with duplicates
  unpack_pieces(a, both);
  unpack_pieces(b, both);
  both.tidy();
  ASSERT_EQ(both.bodies.size(), 4u);
  EXPECT_EQ(both.edges.size(), 3u);
  EXPECT_EQ(both.bodies[both.at(2)].degree, 2u);  // the owner's degree kept over "unknown"
  EXPECT_EQ(both.at(5), both.bodies.size());      // not in any piece
  const ExactClusters whole = exact_clusters(both);
  ASSERT_EQ(whole.count(), 1u);
  EXPECT_TRUE(whole.complete[0]);
  EXPECT_EQ(whole.size(0), 4u);
  EXPECT_EQ(both.bodies[whole.members[whole.start[0]]].id, 1);  // the label: lowest id

  // A degree the merged edges do not reach: incomplete.
  ExactPieces short_of_one = both;
  short_of_one.bodies[short_of_one.at(7)].degree = 2;
  EXPECT_FALSE(exact_clusters(short_of_one).complete[0]);
}

// tidy() finds each edge's bodies (by merging with the sorted ids) where at() does, for edges
// in any order, duplicated, and with ends in no piece; at() finds every body and nothing else.
TEST(ExactProtocol, EveryEdgeFindsItsBodies) {
  for (std::int64_t n = 0; n <= 40; ++n) {
    ExactPieces r;
    for (std::int64_t k = n - 1; k >= 0; --k) r.bodies.push_back(body(3 * k + 5));
    for (std::int64_t k = 0; k < 3 * n; ++k) {
      const std::int64_t a = 3 * ((7 * k) % (n + 1)) + 5, b = 3 * ((11 * k + 3) % (n + 2)) + 5;
      if (a != b) r.edges.push_back({std::min(a, b), std::max(a, b), 1});
    }
    r.tidy();
    ASSERT_EQ(r.bodies.size(), static_cast<std::size_t>(n));
    for (std::int64_t k = 0; k < n; ++k) EXPECT_EQ(r.bodies[r.at(3 * k + 5)].id, 3 * k + 5);
    for (const std::int64_t absent : {std::int64_t{-1}, std::int64_t{4}, 3 * n + 5})
      EXPECT_EQ(r.at(absent), r.bodies.size()) << n << " " << absent;
    ASSERT_EQ(r.ends.size(), r.edges.size());
    for (std::size_t k = 0; k < r.edges.size(); ++k) {
      EXPECT_EQ(r.ends[k].first, r.at(r.edges[k].a)) << n << " " << k;
      EXPECT_EQ(r.ends[k].second, r.at(r.edges[k].b)) << n << " " << k;
      if (k > 0) {
        EXPECT_LT(std::make_pair(r.edges[k - 1].a, r.edges[k - 1].b),
                  std::make_pair(r.edges[k].a, r.edges[k].b));
      }
    }
  }
}

// A tidy set with more pieces added and only the new part sorted (tidy(bodies, edges)) is the set
// tidied whole: the same bodies, with each body's largest degree, the same edges and ends.
TEST(ExactProtocol, TidyingOnlyTheNewPiecesEqualsTidyingAll) {
  for (std::int64_t n = 1; n <= 30; ++n) {
    ExactPieces head;
    for (std::int64_t k = 0; k < n; ++k)
      head.bodies.push_back(body(2 * k + 1, k % 3 == 0 ? 1 : kDegreeUnknown));
    for (std::int64_t k = 0; k + 1 < n; k += 2) head.edges.push_back({2 * k + 1, 2 * k + 3, 1});
    head.tidy();
    ExactPieces all = head, part = head;
    const std::size_t bodies = head.bodies.size(), edges = head.edges.size();
    for (ExactPieces *r : {&all, &part}) {  // new bodies (some known, a higher degree) and edges
      for (std::int64_t k = n + 2; k >= 0; k -= 2)
        r->bodies.push_back(body(k + 1, k % 4 == 0 ? 2 : kDegreeUnknown));
      for (std::int64_t k = 0; k + 2 <= n; ++k)
        r->edges.push_back({k + 1, k + 3, k % 2 == 0 ? 2 : 1});
    }
    all.tidy();
    part.tidy(bodies, edges);
    ASSERT_EQ(part.bodies.size(), all.bodies.size()) << n;
    for (std::size_t k = 0; k < all.bodies.size(); ++k) {
      EXPECT_EQ(part.bodies[k].id, all.bodies[k].id) << n << " " << k;
      EXPECT_EQ(part.bodies[k].degree, all.bodies[k].degree) << n << " " << k;
      EXPECT_EQ(std::memcmp(part.bodies[k].state, all.bodies[k].state, sizeof all.bodies[k].state),
                0);
    }
    ASSERT_EQ(part.edges.size(), all.edges.size()) << n;
    for (std::size_t k = 0; k < all.edges.size(); ++k) {
      EXPECT_EQ(part.edges[k].a, all.edges[k].a);
      EXPECT_EQ(part.edges[k].b, all.edges[k].b);
      EXPECT_EQ(part.edges[k].candidate, all.edges[k].candidate);
    }
    EXPECT_EQ(part.ends, all.ends) << n;
    EXPECT_EQ(part.ids, all.ids) << n;
  }
}

TEST(ExactProtocol, TheScratchProblemHoldsTheClustersBodiesEdgesAndNearPairs) {
  const Chain c;
  ExactPieces r;
  std::vector<char> buf;
  pack_piece(buf, c.a_bodies, c.a_edges);
  pack_piece(buf, c.b_bodies, c.b_edges);
  unpack_pieces(buf, r);
  r.tidy();
  const ExactClusters ec = exact_clusters(r);
  ExactProblem problem;
  const Box box{{20.0, 20.0, 20.0}};
  exact_problem(r, ec, {1}, box, 10.0, problem);
  ASSERT_EQ(problem.bodies.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    const ExactPieces::Body &b = r.bodies[problem.piece[k]];
    EXPECT_EQ(problem.bodies.id[k], b.id);
    double s[kExactState];
    read_exact_state(problem.bodies, k, s);
    EXPECT_EQ(std::memcmp(s, b.state, sizeof s), 0);  // the bits that travelled
  }
  EXPECT_EQ(problem.candidates.size(), 2u);
  ASSERT_EQ(problem.joins.size(), 1u);
  EXPECT_EQ(problem.bodies.id[problem.joins[0].first], 3);
  EXPECT_EQ(problem.bodies.id[problem.joins[0].second], 7);
  // Every pair of the cluster is near (centres within 10): 6 pairs, 12 ends.
  EXPECT_EQ(problem.list.pairs.size(), 6u);
  EXPECT_EQ(problem.list.pair_index.size(), 12u);
  for (std::uint32_t b = 0; b < 4; ++b)
    for (std::uint32_t q = problem.list.pairs_start[b]; q < problem.list.pairs_start[b + 1]; ++q) {
      const ListedPair &p = problem.list.pairs[problem.list.pair_index[q]];
      EXPECT_TRUE(p.first == b || p.second == b);
      EXPECT_EQ(problem.list.pair_partner[q], p.first == b ? p.second : p.first);
    }
  // Centres 0.1 sqrt(3) apart per unit of id: within 0.25 only 1-2 and 2-3.
  exact_problem(r, ec, {1}, box, 0.25, problem);
  ASSERT_EQ(problem.list.pairs.size(), 2u);
  EXPECT_EQ(problem.bodies.id[problem.list.pairs[0].first], 1);
  EXPECT_EQ(problem.bodies.id[problem.list.pairs[1].second], 3);
  exact_problem(r, ec, {0}, box, 10.0, problem);  // nothing taken
  EXPECT_EQ(problem.bodies.size(), 0u);
  EXPECT_TRUE(problem.candidates.empty() && problem.joins.empty() && problem.list.pairs.empty());
}

TEST(ExactProtocol, ResultsCarryTheEndStateAndTheCountedCollisions) {
  FlownBody f;
  f.body = 12;
  f.x = {1.5, -2.25, 3.0};
  f.e = {0.0, 0.6, 0.8};
  f.v = {0.1, 0.2, -0.3};
  f.w = {1e-3, 0.0, 7.0};
  f.overrun = 0.0125;
  f.collisions = 3;
  f.virial.add(2.5);
  f.virial.add(1e-17);
  std::vector<char> buf;
  pack_results(buf, {exact_result(40, 38, 5, &f), exact_result(41, 38, 5, nullptr)});
  std::vector<ExactResult> got;
  unpack_results(buf, got);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].label, 38);
  EXPECT_EQ(got[0].size, 5u);
  EXPECT_TRUE(got[0].flown);
  EXPECT_FALSE(got[1].flown);
  const FlownBody back = flown_body(got[0], 7);
  EXPECT_EQ(back.body, 7u);
  EXPECT_EQ(std::memcmp(&back.x, &f.x, sizeof f.x), 0);
  EXPECT_EQ(std::memcmp(&back.w, &f.w, sizeof f.w), 0);
  EXPECT_EQ(back.overrun, f.overrun);
  EXPECT_EQ(back.collisions, 3);
  EXPECT_TRUE(back.virial.raw() == f.virial.raw());
}

// A message of the pieces' exchange: its results first (none, or some), then its pieces.
TEST(ExactProtocol, AMessageCarriesResultsThenPieces) {
  const Chain c;
  for (const std::size_t count : {0u, 1u, 3u}) {
    std::vector<ExactResult> sent;
    for (std::size_t k = 0; k < count; ++k)
      sent.push_back(exact_result(100 + static_cast<std::int64_t>(k), 100, 3, nullptr));
    std::vector<char> buf;
    pack_results(buf, sent);
    pack_piece(buf, c.a_bodies, c.a_edges);
    pack_piece(buf, c.b_bodies, c.b_edges);
    std::vector<ExactResult> got{exact_result(5, 5, 1, nullptr)};  // appended to
    ExactPieces r;
    unpack_message(buf, got, r);
    ASSERT_EQ(got.size(), count + 1);
    for (std::size_t k = 0; k < count; ++k) EXPECT_EQ(got[k + 1].id, sent[k].id);
    EXPECT_EQ(r.bodies.size(), c.a_bodies.size() + c.b_bodies.size());
    EXPECT_EQ(r.edges.size(), c.a_edges.size() + c.b_edges.size());
    r.tidy();
    EXPECT_EQ(r.bodies.size(), 4u);
  }
  std::vector<char> results_only;  // a message with no pieces
  pack_results(results_only, {exact_result(9, 9, 1, nullptr)});
  std::vector<ExactResult> got;
  ExactPieces r;
  unpack_message(results_only, got, r);
  EXPECT_EQ(got.size(), 1u);
  EXPECT_TRUE(r.bodies.empty() && r.edges.empty());
}

}  // namespace
}  // namespace hardrod
