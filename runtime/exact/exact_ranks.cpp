// Phase 5 of the exact method's step (runtime/exact/exact_step.hpp) on several ranks: the step's
// clusters solved where their bodies live, in rounds agreed by all ranks.
//
// Each rank detects the candidates of the bodies it owns (the pair list keeps the pairs with an
// owned body), so a cluster's edges are the union of its owners'. A round:
//   1. the components of this rank's edges (candidates and the joins agreed so far) over the
//      bodies it advances; a component of bodies this rank owns is a whole cluster and is
//      solved here (collide_once: on one thread the changed ones together in one queue,
//      confined to their bodies); where other ranks hold some of its bodies (as shadows),
//      their results go to them with the next exchange. A component with a shadow is
//      *spanning*;
//   2. each spanning component goes as a piece (bodies at the step's start, edges, the owned
//      bodies' degrees) to every owner and holder of its bodies; a rank merges what it gets
//      with its own and solves every complete merged cluster that has a body it advances, on
//      a scratch problem: the same bodies and edges give the same bits on every rank. On two
//      ranks one exchange gives every rank its clusters whole (the argument of
//      runtime/spanning_clusters.cpp carries over: edges, like contacts, are known to the
//      owners of both bodies); on more, pieces are forwarded until they do (forward_pieces);
//   3. the overrun check (overrun_reaches) over this rank's listed pairs: the joins it finds
//      are found by the owners of both bodies, since both hold both bodies' results;
//   4. one max-reduction: new joins anywhere, a body left unresolved, the largest reach. With
//      joins, the next round solves again what they changed (on more than two ranks also
//      every spanning component, see collide_on_ranks).
// This is the kernel's own loop (collide_exactly: solve, check, join, solve the joined again)
// with ranks in it, so the final clusters are the one-rank run's and so are the bits. Each
// collision and its virial is counted by the owner of its lower-id body (FlownBody); the
// counts of work (searches, events) are each rank's, so a cluster solved on two ranks counts
// twice.
#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "kernels/union_find.hpp"
#include "runtime/exact/exact_protocol.hpp"
#include "runtime/exact/exact_step.hpp"

namespace hardrod {

namespace {

constexpr std::uint32_t kNoBody = std::numeric_limits<std::uint32_t>::max();

}  // namespace

// The connected components of a round's edges over the advanced bodies.
struct ExactComponents {
  std::vector<std::uint32_t> comp_of;  // by body; kNoSet: in no edge
  std::vector<std::uint32_t> start{0}, bodies;
  std::vector<char> spanning;  // by component: a body other ranks own (a shadow here)
  std::vector<char> held;      // by component: only owned bodies, one of them held elsewhere

  std::size_t count() const { return spanning.size(); }
};

// What the rounds of one step carry from round to round: the joins, and every body's result,
// which stands until a join changes its cluster.
struct ExactRound {
  std::vector<BodyPair> joins;          // agreed so far (this rank's, local indices)
  std::vector<std::int64_t> label;      // by body: its cluster's lowest id (-1: not solved)
  std::vector<std::uint32_t> size;      // by body: its cluster's size
  std::vector<FlownBody> flown;         // results, including replaced ones (see flown_at)
  std::vector<std::uint32_t> flown_at;  // by body: its result in `flown` (kNoBody: none)
  // By body: in a join of the last round (round 0: all; on more than two ranks every shadow).
  std::vector<char> dirty;
  std::vector<ExactResult> outgoing;  // results of held components, for the next exchange
  ExactPieces pieces;                 // every piece sent or received in the step
  ExactStats work;                    // every round's passes
  long long unresolved = 0;           // advanced bodies of spanning clusters left unsolved

  // By body: its result changed in this round (touched_list: which); the overrun check's marks.
  std::vector<char> touched, check;
  std::vector<std::uint32_t> touched_list, check_list;

  void touch(std::uint32_t b) {
    if (!touched[b]) touched[b] = 1, touched_list.push_back(b);
  }
  void forget(std::uint32_t b) {
    label[b] = -1;
    flown_at[b] = kNoBody;
    touch(b);
  }
  // Body b's result, unless it has one.
  void settle(std::uint32_t b, std::int64_t cluster, std::uint32_t n, const FlownBody *f) {
    if (label[b] != -1) return;
    touch(b);
    label[b] = cluster;
    size[b] = n;
    if (f == nullptr) return;
    flown_at[b] = static_cast<std::uint32_t>(flown.size());
    flown.push_back(*f);
    flown.back().body = b;
  }
  // By component: whether it has a body a join of the last round touched (dirty). The bodies of
  // such a component lose their results: it is solved again.
  std::vector<char> take_changed(const ExactComponents &cc) {
    std::vector<char> changed(cc.count(), 0);
    for (std::size_t c = 0; c < cc.count(); ++c) {
      for (std::uint32_t k = cc.start[c]; k < cc.start[c + 1]; ++k)
        changed[c] = changed[c] || dirty[cc.bodies[k]];
      if (changed[c])
        for (std::uint32_t k = cc.start[c]; k < cc.start[c + 1]; ++k) forget(cc.bodies[k]);
    }
    return changed;
  }
  // The next round after `found` joins. On two ranks (`incremental`) every rank holding a body
  // of a changed cluster gets the changed piece (the argument of one exchange), merged with the
  // earlier pieces. With more, a rank may know a cluster only through pieces forwarded by
  // others and cannot tell it changed; an earlier piece could even make a changed cluster look
  // complete: every spanning component (one with a shadow) goes again, and the step's earlier
  // pieces are dropped. A component of owned bodies changes only by a join of one of its
  // bodies, which its owner finds: on any number of ranks only those are solved again.
  void next_round(const std::vector<BodyPair> &found, bool incremental, std::size_t owned) {
    std::fill(dirty.begin(), dirty.end(), 0);
    if (!incremental) {
      pieces = ExactPieces();
      std::fill(dirty.begin() + static_cast<long>(owned), dirty.end(), 1);
    }
    for (const auto &[a, b] : found) dirty[a] = dirty[b] = 1;
    joins.insert(joins.end(), found.begin(), found.end());
  }
  // The bodies whose pairs the overrun check takes this round: in the first every flown body
  // (nullptr); later only the bodies whose results changed in the round and their listed
  // partners. A pair of two unchanged bodies was checked with the same results in an earlier
  // round and made no join there (a join changes both its bodies' clusters).
  const std::vector<char> *take_checks(const NeighborList &list, bool first) {
    const std::vector<char> *out = nullptr;
    if (!first) {
      for (const std::uint32_t b : check_list) check[b] = 0;
      check_list.clear();
      const auto mark = [&](std::uint32_t b) {
        if (!check[b]) check[b] = 1, check_list.push_back(b);
      };
      for (const std::uint32_t b : touched_list) {
        mark(b);
        for (std::uint32_t q = list.pairs_start[b]; q < list.pairs_end[b]; ++q)
          mark(list.pair_partner[q]);
      }
      out = &check;
    }
    for (const std::uint32_t b : touched_list) touched[b] = 0;
    touched_list.clear();
    return out;
  }
  // The standing results of the bodies whose velocity changed.
  std::vector<FlownBody> current() const {
    std::vector<FlownBody> out;
    for (std::uint32_t q = 0; q < flown.size(); ++q)
      if (flown_at[flown[q].body] == q) out.push_back(flown[q]);
    return out;
  }
};

namespace {

// A component with a shadow is spanning: its owners hold edges of it this rank lacks. A
// component of owned bodies only is whole here (every pair of a body owned here is in this
// rank's list), even where other ranks hold its bodies (it is *held*): they know none of its
// edges (their lists keep the pairs with a body they own) and need only its results.
ExactComponents components(std::size_t n, std::size_t owned,
                           const std::vector<Candidate> &candidates,
                           const std::vector<BodyPair> &joins, const std::vector<char> &shared) {
  std::vector<std::uint32_t> parent(n, kNoBody), involved;
  const auto edge = [&](std::uint32_t a, std::uint32_t b) {
    for (const std::uint32_t x : {a, b})
      if (parent[x] == kNoBody) parent[x] = x, involved.push_back(x);
    join_sets(parent, a, b);
  };
  for (const Candidate &c : candidates) edge(c.i, c.j);
  for (const auto &[a, b] : joins) edge(a, b);
  ExactComponents cc;
  cc.comp_of.assign(n, kNoSet);
  cc.spanning.assign(list_sets(parent, involved, cc.comp_of, cc.start, cc.bodies), 0);
  cc.held.assign(cc.count(), 0);
  for (const std::uint32_t b : involved) {
    if (b >= owned) cc.spanning[cc.comp_of[b]] = 1;
    if (shared[b]) cc.held[cc.comp_of[b]] = 1;
  }
  for (std::size_t c = 0; c < cc.count(); ++c) cc.held[c] = cc.held[c] && !cc.spanning[c];
  return cc;
}

// By cluster: whether it has a body of this round's pieces (`fresh`, sorted ids), i.e. is new
// or changed since the last round; found by one merge of the two sorted lists of ids.
std::vector<char> renewed_clusters(const ExactPieces &pieces, const ExactClusters &ec,
                                   const std::vector<std::int64_t> &fresh) {
  const std::vector<std::int64_t> &ids = pieces.ids;
  std::vector<char> renewed(ec.count(), 0);
  std::size_t f = 0;
  for (std::size_t b = 0; b < ids.size(); ++b) {
    while (f < fresh.size() && fresh[f] < ids[b]) ++f;
    if (f < fresh.size() && fresh[f] == ids[b]) renewed[ec.cluster_of[b]] = 1;
  }
  return renewed;
}

}  // namespace

// Phase 5 on several ranks; `reach` gets the largest flight of a flown body on any rank (the
// list expires if it passes half the skin: the caller solves the step again on a new list).
ExactStats ExactStep::collide_on_ranks(System &sys, double &reach) {
  const std::size_t n = sys.advanced();
  ExactRound round;
  round.label.assign(n, -1);
  round.size.assign(n, 0);
  round.flown_at.assign(n, kNoBody);
  round.dirty.assign(n, 1);
  round.touched.assign(n, 0);
  round.check.assign(n, 0);
  const bool incremental = sys.comm().size() == 2 && !results_path(sys.comm().size());
  std::vector<double> overrun_scratch;
  for (bool first = true;; first = false) {
    const ExactComponents cc =
        components(n, sys.owned_count(), candidates_, round.joins, sys.shared());
    const std::vector<char> changed = round.take_changed(cc);
    solve_local_components(sys, round, cc, changed);
    solve_spanning_components(sys, round, cc, changed);
    const std::vector<FlownBody> flown = round.current();
    const std::vector<BodyPair> joins =
        overrun_reaches(sys.particles(), sys.scene().box, sys.scene().shape, sys.list(), flown,
                        round.label, overrun_scratch, round.take_checks(sys.list(), first));
    double largest = 0.0;
    for (const FlownBody &f : flown)
      largest = std::max(largest, sys.particles().motion_bound[f.body] + f.overrun);
    std::vector<double> flags{static_cast<double>(joins.size()),
                              static_cast<double>(round.unresolved), largest};
    {
      ScopedRegion r(sys.timers(), Region::kAgree);
      flags = sys.comm().max("exact_round", flags);
    }
    if (flags[1] > 0.0)
      sys.fail(
          fmt::format("step {}: a cluster of the exact method that spans ranks reached a rank "
                      "only in part ({} bodies left unsolved)",
                      sys.current_step() + 1, flags[1]));
    if (flags[0] == 0.0) {
      reach = flags[2];
      flown_ = flown;
      return exact_counts(sys, round, flown);
    }
    for (const auto &[a, b] : joins)  // each join counted by the owner of its lower-id body
      round.work.regrown +=
          (sys.particles().id[a] < sys.particles().id[b] ? a : b) < sys.owned_count();
    round.next_round(joins, incremental,
                     sys.owned_count());  // the components the joins changed go again
  }
}

// The changed components of owned bodies only: solved here; for the bodies other ranks hold,
// results for the next exchange. In a step's first round only those whose velocity changed
// (the holders have nothing to replace); after joins every one, so that a result from an
// earlier round is replaced even where the body no longer collides.
void ExactStep::solve_local_components(System &sys, ExactRound &round, const ExactComponents &cc,
                                       const std::vector<char> &changed) {
  std::vector<char> solve(cc.count(), 0);
  for (std::size_t c = 0; c < cc.count(); ++c) solve[c] = changed[c] && !cc.spanning[c];
  std::vector<Candidate> candidates;
  for (const Candidate &ct : candidates_)
    if (solve[cc.comp_of[ct.i]]) candidates.push_back(ct);
  std::vector<BodyPair> joins;
  for (const BodyPair &j : round.joins)
    if (solve[cc.comp_of[j.first]]) joins.push_back(j);
  std::vector<FlownBody> flown;
  round.work += collide_once(sys.particles(), sys.scene().box, sys.scene().shape, sys.list(),
                             candidates, joins, sys.scene().dt, settings_, scratch_, flown);
  std::vector<const FlownBody *> flown_of(sys.advanced(), nullptr);
  for (const FlownBody &f : flown) flown_of[f.body] = &f;
  const bool first_round = round.joins.empty();
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (!solve[c]) continue;
    const std::uint32_t *first = cc.bodies.data() + cc.start[c];
    const std::uint32_t *last = cc.bodies.data() + cc.start[c + 1];
    std::int64_t lowest = std::numeric_limits<std::int64_t>::max();  // the cluster's label
    for (const std::uint32_t *b = first; b != last; ++b)
      lowest = std::min(lowest, sys.particles().id[*b]);
    const auto size = static_cast<std::uint32_t>(last - first);
    for (const std::uint32_t *b = first; b != last; ++b) {
      round.settle(*b, lowest, size, flown_of[*b]);
      if (!cc.held[c] || !sys.shared()[*b] || (flown_of[*b] == nullptr && first_round)) continue;
      round.outgoing.push_back(exact_result(sys.particles().id[*b], lowest, size, flown_of[*b]));
    }
  }
}

// The spanning components: pieces of the changed ones to the owners and holders of their
// bodies, merged with every piece of the step; the complete merged clusters that changed (a body
// in this round's pieces) and have a body advanced here are solved here; results where needed.
void ExactStep::solve_spanning_components(System &sys, ExactRound &round, const ExactComponents &cc,
                                          const std::vector<char> &changed) {
  std::vector<std::int64_t> fresh = exchange_pieces(sys, round, cc, changed);
  std::sort(fresh.begin(), fresh.end());
  if (sys.comm().size() > 2) forward_pieces(sys, round, fresh);
  ExactPieces &pieces = round.pieces;
  const ExactClusters ec = exact_clusters(pieces);
  // Of the renewed clusters' bodies: the local index if advanced here.
  std::vector<std::uint32_t> where(pieces.bodies.size(), kNoBody);
  const std::vector<char> renewed = renewed_clusters(pieces, ec, fresh);
  std::vector<char> take(ec.count(), 0);
  for (std::size_t c = 0; c < ec.count(); ++c) {
    if (!renewed[c]) continue;
    const std::uint32_t *first = ec.members.data() + ec.start[c];
    const std::uint32_t *last = ec.members.data() + ec.start[c + 1];
    bool held = false;
    for (const std::uint32_t *b = first; b != last; ++b) {
      const std::size_t at = sys.advanced_index(pieces.bodies[*b].id);
      if (at == System::kNotAdvanced) continue;
      where[*b] = static_cast<std::uint32_t>(at);
      round.forget(where[*b]);
      held = true;
    }
    take[c] = ec.complete[c] && held &&
              (!results_path(sys.comm().size()) || where[*first] < sys.owned_count());
    record_.resolved += take[c];
  }
  ExactProblem &problem = problem_;
  const double near = sys.scene().shape.length + sys.scene().shape.diameter + 2.0 * sys.list().skin;
  exact_problem(pieces, ec, take, sys.scene().box, near, problem);
  // By cluster, never in one queue: a rank solves the complete clusters it has a body of, and
  // each cluster must come out the same on every rank that solves it, whatever else it solves.
  ExactSettings by_cluster = settings_;
  by_cluster.one_queue = false;
  std::vector<FlownBody> flown;
  round.work +=
      collide_once(problem.bodies, sys.scene().box, sys.scene().shape, problem.list,
                   problem.candidates, problem.joins, sys.scene().dt, by_cluster, scratch_, flown);
  // Every body of a solved cluster, as a result (by work index).
  std::vector<const FlownBody *> flown_of(problem.piece.size(), nullptr);
  for (const FlownBody &f : flown) flown_of[f.body] = &f;
  std::vector<ExactResult> results;
  for (std::uint32_t k = 0; k < problem.piece.size(); ++k) {
    const std::uint32_t pb = problem.piece[k];
    const std::uint32_t c = ec.cluster_of[pb];
    results.push_back(exact_result(pieces.bodies[pb].id, pieces.bodies[ec.members[ec.start[c]]].id,
                                   ec.size(c), flown_of[k]));
    if (where[pb] != kNoBody) settle_exact(round, where[pb], results.back());
  }
  if (results_path(sys.comm().size())) exchange_exact_results(sys, round, results);
  // Every advanced body of a spanning cluster is in its owner's piece, which came here.
  round.unresolved = 0;
  for (const std::uint32_t b : where) round.unresolved += b != kNoBody && round.label[b] == -1;
}

// On more than two ranks a rank can get a cluster in part (a chain X-A-B, X held here, A and
// B owned by two other ranks, B not held here: runtime/spanning_clusters.cpp). Until no rank
// lacks a piece of a renewed cluster with a body it advances, every rank forwards what it
// knows of the renewed clusters to the owners and holders of their bodies it holds: each
// forwarding reaches one rank further along the cluster (an edge's two owners hold both its
// bodies, so the ranks of a cluster are linked by bodies they share). `fresh` gains the
// forwarded bodies.
void ExactStep::forward_pieces(System &sys, ExactRound &round, std::vector<std::int64_t> &fresh) {
  ExactPieces &pieces = round.pieces;
  for (int hop = 0; hop < sys.comm().size(); ++hop) {
    const ExactClusters ec = exact_clusters(pieces);
    const std::vector<char> renewed = renewed_clusters(pieces, ec, fresh);
    double needy = 0.0;
    for (std::size_t c = 0; c < ec.count(); ++c) {
      if (!renewed[c] || ec.complete[c]) continue;
      for (std::uint32_t k = ec.start[c]; k < ec.start[c + 1]; ++k) {
        if (sys.advanced_index(pieces.bodies[ec.members[k]].id) != System::kNotAdvanced)
          needy = 1.0;
      }
    }
    {
      ScopedRegion r(sys.timers(), Region::kAgree);
      if (sys.comm().max("exact_round", {needy})[0] == 0.0) return;
    }
    std::vector<std::vector<ExactPieces::Edge>> edges(ec.count());
    for (std::size_t k = 0; k < pieces.edges.size(); ++k)
      edges[ec.cluster_of[pieces.ends[k].first]].push_back(pieces.edges[k]);
    open_messages(sys, {});
    std::vector<ExactPieces::Body> bodies;
    for (std::size_t c = 0; c < ec.count(); ++c) {
      if (!renewed[c]) continue;
      bodies.clear();
      for (std::uint32_t k = ec.start[c]; k < ec.start[c + 1]; ++k)
        bodies.push_back(pieces.bodies[ec.members[k]]);
      forward_piece(sys, bodies, edges[c]);
    }
    std::vector<ExactResult> none;
    swap_pieces(sys, pieces, pieces.bodies.size(), pieces.edges.size(), fresh, none);
    std::sort(fresh.begin(), fresh.end());
    fresh.erase(std::unique(fresh.begin(), fresh.end()), fresh.end());
  }
}

// One piece into the messages (out_) to the owners and holders of its bodies.
void ExactStep::post_piece(const System &sys, const std::vector<ExactPieces::Body> &bodies,
                           const std::vector<ExactPieces::Edge> &edges) {
  std::vector<int> targets;
  for (const ExactPieces::Body &b : bodies) sys.add_targets(b.id, targets);
  sort_unique(targets);
  for (int r : targets) pack_piece(out_[sys.domain().partner_slot(r)], bodies, edges);
}

// The messages to the partners (out_) emptied, each opened with `results` for the
// bodies that partner owns or holds (unpack_message's order).
void ExactStep::open_messages(const System &sys, const std::vector<ExactResult> &results) {
  std::vector<std::vector<ExactResult>> to(sys.domain().partners().size());
  std::vector<int> targets;
  for (const ExactResult &r : results) {
    targets.clear();
    sys.add_targets(r.id, targets);
    for (int t : targets) to[sys.domain().partner_slot(t)].push_back(r);
  }
  out_.resize(to.size());
  for (std::size_t s = 0; s < to.size(); ++s) {
    out_[s].clear();
    pack_results(out_[s], to[s]);
  }
}

// One renewed cluster forwarded to the owners and holders of its bodies that may lack a piece of
// it. Every piece of a round went from its rank to the owners and holders of all its bodies, so
// a rank that owns or holds every body of the cluster got each piece first hand: it is skipped.
// Whether a rank holds a body is known here only for the bodies held here; one not held here
// may be missing there, and the cluster goes.
void ExactStep::forward_piece(System &sys, const std::vector<ExactPieces::Body> &bodies,
                              const std::vector<ExactPieces::Edge> &edges) {
  std::vector<const System::Holding *> held(bodies.size());
  std::vector<int> targets;
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    held[k] = sys.holding(bodies[k].id);
    if (held[k] == nullptr) continue;
    targets.push_back(held[k]->owner);
    targets.insert(targets.end(), held[k]->holders.begin(), held[k]->holders.end());
  }
  sort_unique(targets);
  for (int r : targets) {
    if (r == sys.comm().rank()) continue;
    const bool has_all = std::all_of(held.begin(), held.end(), [r](const System::Holding *h) {
      return h != nullptr && h->has(r);
    });
    if (!has_all) pack_piece(out_[sys.domain().partner_slot(r)], bodies, edges);
  }
}

// The posted messages exchanged with the partners: the results that arrive into `results`,
// the pieces added to `pieces`, tidied; `fresh` gains the ids of every body added to `pieces`
// since it held `first` bodies and `first_edge` edges, which were tidy.
void ExactStep::swap_pieces(System &sys, ExactPieces &pieces, std::size_t first,
                            std::size_t first_edge, std::vector<std::int64_t> &fresh,
                            std::vector<ExactResult> &results) {
  for (const auto &buf : sys.comm().exchange("exact_pieces", sys.domain().partners(), out_))
    unpack_message(buf, results, pieces);
  for (std::size_t k = first; k < pieces.bodies.size(); ++k) fresh.push_back(pieces.bodies[k].id);
  pieces.tidy(first, first_edge);
}

// A held component's result from its owner, in place of any earlier one.
void ExactStep::replace_exact(const System &sys, ExactRound &round, const ExactResult &r) const {
  const std::size_t at = sys.advanced_index(r.id);
  if (at == System::kNotAdvanced) return;
  const auto b = static_cast<std::uint32_t>(at);
  round.forget(b);
  settle_exact(round, b, r);
}

void ExactStep::settle_exact(ExactRound &round, std::uint32_t b, const ExactResult &r) const {
  if (round.label[b] != -1) return;
  if (!r.flown) return round.settle(b, r.label, r.size, nullptr);
  const FlownBody f = flown_body(r, b);
  round.settle(b, r.label, r.size, &f);
}

// This rank's results of held components and pieces of the changed spanning components, to
// the owners and holders of their bodies; what the partners sent: their results settled, their
// pieces added to the step's pieces (tidy). Returns the ids of the bodies in this round's
// pieces.
std::vector<std::int64_t> ExactStep::exchange_pieces(System &sys, ExactRound &round,
                                                     const ExactComponents &cc,
                                                     const std::vector<char> &changed) {
  ++record_.exchanges;
  open_messages(sys, round.outgoing);
  round.outgoing.clear();
  ExactPieces &pieces = round.pieces;
  const std::size_t first_new = pieces.bodies.size(), first_edge = pieces.edges.size();
  // Each body's edges here, as ids (a < b): its candidates and joins; those of the components
  // that go, by component (a counting sort, stable: one flat array, not a vector each).
  std::vector<std::uint32_t> degree(sys.advanced(), 0);
  std::vector<std::pair<std::uint32_t, ExactPieces::Edge>> tagged;
  const auto add_edge = [&](std::uint32_t a, std::uint32_t b, std::int32_t kind) {
    ++degree[a], ++degree[b];
    const std::uint32_t c = cc.comp_of[a];
    if (!cc.spanning[c] || !changed[c]) return;
    std::int64_t ia = sys.particles().id[a], ib = sys.particles().id[b];
    if (ia > ib) std::swap(ia, ib);
    tagged.push_back({c, {ia, ib, kind}});
  };
  for (const Candidate &ct : candidates_) add_edge(ct.i, ct.j, ct.apart ? 2 : 1);
  for (const auto &[a, b] : round.joins) add_edge(a, b, 0);
  std::vector<std::uint32_t> edges_start(cc.count() + 1, 0);
  for (const auto &t : tagged) ++edges_start[t.first + 1];
  for (std::size_t c = 0; c < cc.count(); ++c) edges_start[c + 1] += edges_start[c];
  std::vector<ExactPieces::Edge> by_component(tagged.size());
  {
    std::vector<std::uint32_t> at(edges_start.begin(), edges_start.end() - 1);
    for (const auto &[c, e] : tagged) by_component[at[c]++] = e;
  }
  std::vector<ExactPieces::Body> bodies;
  std::vector<ExactPieces::Edge> edges;
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (!cc.spanning[c] || !changed[c]) continue;
    edges.assign(by_component.begin() + edges_start[c], by_component.begin() + edges_start[c + 1]);
    bodies.clear();
    for (std::uint32_t k = cc.start[c]; k < cc.start[c + 1]; ++k) {
      const std::uint32_t b = cc.bodies[k];
      ExactPieces::Body body;
      body.id = sys.particles().id[b];
      body.degree = b < sys.owned_count() ? degree[b] : kDegreeUnknown;
      read_exact_state(sys.particles(), b, body.state);
      bodies.push_back(body);
    }
    post_piece(sys, bodies, edges);
    pieces.bodies.insert(pieces.bodies.end(), bodies.begin(), bodies.end());
    pieces.edges.insert(pieces.edges.end(), edges.begin(), edges.end());
  }
  std::vector<std::int64_t> fresh;
  std::vector<ExactResult> results;
  swap_pieces(sys, pieces, first_new, first_edge, fresh, results);
  for (const ExactResult &r : results) replace_exact(sys, round, r);
  return fresh;
}

// For clusters that reached a rank only in part: every solved cluster's results to the owners
// and holders of its bodies that this rank knows (duplicates carry the same bits).
void ExactStep::exchange_exact_results(System &sys, ExactRound &round,
                                       const std::vector<ExactResult> &results) {
  const auto &partners = sys.domain().partners();
  std::vector<std::vector<char>> &out = out_;
  for (auto &o : out) o.clear();
  // Every result goes to every target of any body of its cluster: gather targets by label.
  std::vector<int> targets;
  for (std::size_t k = 0; k < results.size();) {
    std::size_t end = k;
    targets.clear();
    while (end < results.size() && results[end].label == results[k].label)
      sys.add_targets(results[end++].id, targets);
    sort_unique(targets);
    const std::vector<ExactResult> cluster(results.begin() + static_cast<long>(k),
                                           results.begin() + static_cast<long>(end));
    for (int r : targets) pack_results(out[sys.domain().partner_slot(r)], cluster);
    k = end;
  }
  std::vector<ExactResult> got;
  for (const auto &buf : sys.comm().exchange("exact_results", partners, out))
    unpack_results(buf, got);
  for (const ExactResult &r : got) {
    const std::size_t at = sys.advanced_index(r.id);
    if (at == System::kNotAdvanced) continue;
    const auto b = static_cast<std::uint32_t>(at);
    record_.from_results += round.label[b] == -1;
    settle_exact(round, b, r);
  }
}

// The step's counts: collisions and virial of the flown bodies this rank owns, clusters whose
// lowest id it owns, candidates whose lower-id body it owns; the work of every round here.
ExactStats ExactStep::exact_counts(const System &sys, const ExactRound &round,
                                   const std::vector<FlownBody> &flown) const {
  ExactStats s = round.work;
  s.collisions = s.clusters = s.largest_cluster = s.candidates = s.apart = s.spares = 0;
  s.virial = ExactSum();
  for (const FlownBody &f : flown) {
    if (f.body >= sys.owned_count()) continue;
    s.collisions += f.collisions;
    s.virial += f.virial;
  }
  for (std::uint32_t b = 0; b < sys.owned_count(); ++b) {
    if (round.label[b] != sys.particles().id[b]) continue;
    ++s.clusters;
    s.largest_cluster = std::max<long long>(s.largest_cluster, round.size[b]);
  }
  for (const Candidate &c : candidates_) {
    if (c.i >= sys.owned_count()) continue;
    s.spares += c.spare;
    s.candidates += !c.spare;
    s.apart += c.apart && !c.spare;
  }
  return s;
}

}  // namespace hardrod
