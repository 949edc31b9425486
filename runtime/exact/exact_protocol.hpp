// The exact method's clusters across ranks, without MPI: what ranks tell each other of the
// clusters whose bodies live on several ranks (pieces and results), their wire format, the
// clusters found in merged pieces and the scratch problem that solves them.
// ExactStep::collide_on_ranks (runtime/exact/exact_ranks.cpp) runs the exchanges.
//
// A cluster's *edges* are its candidates (listed pairs that could touch in the step) and its
// joins (pairs whose bodies' overruns could reach each other, agreed in earlier rounds). Every
// edge is known to the owner of each of its bodies, so a body's owner knows its *degree* (its
// edges); a merged cluster is complete when every body's degree is known and equals the edges
// listed for it. A body or edge seen by two ranks carries the same bits on both, so duplicates
// are dropped by id. The solver predicts a pair again after a collision only if the pair list
// holds it; the scratch problem lists every pair of a cluster near enough to be in any rank's
// list (a superset: a pair no list holds cannot touch before the lists expire).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/contact.hpp"
#include "kernels/exact/exact_collisions.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "runtime/body_wire.hpp"

namespace hardrod {

// A body's state at the step's start as the solver reads it: x, e, v, w, and its growth per
// half step (the flight its bound was grown by is twice that).
inline constexpr std::size_t kExactState = 13;

struct ExactPieces {
  struct Body {
    std::int64_t id = 0;
    std::uint32_t degree = kDegreeUnknown;  // from the owner
    double state[kExactState] = {};
  };
  struct Edge {
    std::int64_t a = 0, b = 0;  // a < b
    // 1: a candidate; 2: one proven apart (Candidate::apart); 0: a join
    std::int32_t candidate = 0;
  };
  std::vector<Body> bodies;                                   // by id after tidy()
  std::vector<Edge> edges;                                    // by (a, b) after tidy()
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ends;  // edges' bodies (after tidy())
  std::vector<std::int64_t> ids;  // the bodies' ids, compact for the merges (after tidy())

  // Sorts and drops duplicates, keeping a body's largest known degree (its owner's, which
  // grows with the joins of later rounds), and finds every edge's bodies. The first
  // `tidy_bodies` bodies and `tidy_edges` edges may be left by an earlier tidy() (in order,
  // without duplicates): only what came after them is sorted.
  void tidy(std::size_t tidy_bodies = 0, std::size_t tidy_edges = 0);
  // Position of body `id` in `bodies` (bodies.size() if absent; after tidy()): one lookup, the
  // reference the ends that tidy() merges are tested against.
  std::uint32_t at(std::int64_t id) const;
};

void read_exact_state(const Particles &p, std::size_t i, double (&s)[kExactState]);
void write_exact_state(Particles &p, std::size_t i, const double (&s)[kExactState]);

// Appends one piece (its bodies and edges) to `buf`; unpack_pieces appends every piece in `buf`
// to `r` (untidy).
void pack_piece(std::vector<char> &buf, const std::vector<ExactPieces::Body> &bodies,
                const std::vector<ExactPieces::Edge> &edges);
void unpack_pieces(const std::vector<char> &buf, ExactPieces &r);

// The clusters of tidy pieces: bodies connected by edges, each cluster's bodies in id order,
// clusters ordered by their lowest id (their label).
struct ExactClusters {
  std::vector<std::uint32_t> cluster_of;  // by piece body
  std::vector<std::uint32_t> start;       // cluster c: members[start[c] .. start[c + 1])
  std::vector<std::uint32_t> members;     // piece bodies
  std::vector<char> complete;             // by cluster

  std::size_t count() const { return complete.size(); }
  std::uint32_t size(std::size_t c) const { return start[c + 1] - start[c]; }
};
ExactClusters exact_clusters(const ExactPieces &r);

// The scratch problem of the clusters with take[c] != 0: their bodies (cluster by cluster, in
// id order), the candidates and joins, and as a pair list every pair inside a cluster whose
// centres are closer than `near` (pass L + D + 2 skin: a listed pair's segments were closer
// than D + skin at the build, and each body has moved less than skin / 2 since).
// piece[k] is work body k's place in the pieces.
struct ExactProblem {
  Particles bodies;
  NeighborList list;
  std::vector<Candidate> candidates;
  std::vector<BodyPair> joins;
  std::vector<std::uint32_t> piece;
};
void exact_problem(const ExactPieces &r, const ExactClusters &ec, const std::vector<char> &take,
                   const Box &box, double near, ExactProblem &problem);

// What a rank learnt of one body of a cluster it solved: the cluster (its lowest id and size),
// and for a body whose velocity changed, its end state, overrun and the collisions it counts.
struct ExactResult {
  std::int64_t id = 0;
  std::int64_t label = 0;
  std::uint32_t size = 0;
  std::int32_t flown = 0;
  double state[12] = {};  // x, e, v, w at the step's end
  double overrun = 0.0;
  long long collisions = 0;
  Int128 virial = 0;
  std::int32_t poisoned = 0;
};
ExactResult exact_result(std::int64_t id, std::int64_t label, std::uint32_t size,
                         const FlownBody *flown);
// The FlownBody of local body `body` from a result (flown != 0).
FlownBody flown_body(const ExactResult &r, std::uint32_t body);

void pack_results(std::vector<char> &buf, const std::vector<ExactResult> &results);
void unpack_results(const std::vector<char> &buf, std::vector<ExactResult> &out);

// A message of the pieces' exchange: one array of results (pack_results; the clusters the
// sender solved whole, for bodies the receiver holds; possibly none), then pieces (pack_piece).
// Appends the results to `results` and the pieces to `r` (untidy).
void unpack_message(const std::vector<char> &buf, std::vector<ExactResult> &results,
                    ExactPieces &r);

}  // namespace hardrod
