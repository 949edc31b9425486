#include "runtime/exact/exact_protocol.hpp"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <type_traits>

#include "kernels/union_find.hpp"
#include "runtime/comm.hpp"

namespace hardrod {

namespace {

// A count, then the elements' bytes (the records are plain data, the same on every rank).
template <class T>
void pack_array(std::vector<char> &buf, const std::vector<T> &v) {
  static_assert(std::is_trivially_copyable_v<T>);
  pack(buf, static_cast<std::uint64_t>(v.size()));
  const auto *p = reinterpret_cast<const char *>(v.data());
  buf.insert(buf.end(), p, p + v.size() * sizeof(T));
}

template <class T>
void unpack_array(const std::vector<char> &buf, std::size_t &off, std::vector<T> &out) {
  const auto n = static_cast<std::size_t>(unpack<std::uint64_t>(buf, off));
  const std::size_t first = out.size();
  out.resize(first + n);
  std::memcpy(static_cast<void *>(out.data() + first), buf.data() + off, n * sizeof(T));
  off += n * sizeof(T);
}

// Each edge's bodies by two merges with the sorted ids rather than a search per end: the edges
// are in the order of their first ids, and their second ids are put in order by a sort.
void find_ends(const std::vector<std::int64_t> &ids, const std::vector<ExactPieces::Edge> &edges,
               std::vector<std::pair<std::uint32_t, std::uint32_t>> &ends) {
  const auto n = static_cast<std::uint32_t>(ids.size());
  const auto merge = [&](std::uint32_t &at, std::int64_t id) {
    while (at < n && ids[at] < id) ++at;
    return at < n && ids[at] == id ? at : n;
  };
  ends.resize(edges.size());
  std::uint32_t at = 0;
  for (std::size_t k = 0; k < edges.size(); ++k) ends[k].first = merge(at, edges[k].a);
  std::vector<std::pair<std::int64_t, std::uint32_t>> second(edges.size());
  for (std::size_t k = 0; k < edges.size(); ++k)
    second[k] = {edges[k].b, static_cast<std::uint32_t>(k)};
  std::sort(second.begin(), second.end());
  at = 0;
  for (const auto &[id, k] : second) ends[k].second = merge(at, id);
}

}  // namespace

void ExactPieces::tidy(std::size_t tidy_bodies, std::size_t tidy_edges) {
  if (tidy_bodies == bodies.size() && tidy_edges == edges.size() && ends.size() == edges.size())
    return;  // nothing new since the last tidy
  // Sorted through compact keys (a body is 120 bytes): by id, a body's largest known degree
  // first (a join in a later round raises it), and the first of each id kept. Bodies of one id
  // and degree carry the same bits, so which of them is kept does not matter. The tidy head is
  // in that order already: only the new bodies are sorted, then merged with it.
  struct Key {
    std::int64_t id;
    std::int64_t degree;  // -1: unknown
    std::uint32_t at;
  };
  const auto before = [](const Key &a, const Key &b) {
    return a.id != b.id ? a.id < b.id : a.degree > b.degree;
  };
  std::vector<Key> keys(bodies.size());
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    const std::uint32_t d = bodies[k].degree;
    keys[k] = {bodies[k].id, d == kDegreeUnknown ? -1 : std::int64_t{d},
               static_cast<std::uint32_t>(k)};
  }
  const auto head = keys.begin() + static_cast<std::ptrdiff_t>(tidy_bodies);
  std::sort(head, keys.end(), before);
  std::inplace_merge(keys.begin(), head, keys.end(), before);
  std::vector<Body> sorted;
  sorted.reserve(keys.size());
  ids.clear();
  for (const Key &k : keys)
    if (ids.empty() || ids.back() != k.id) {
      sorted.push_back(bodies[k.at]);
      ids.push_back(k.id);
    }
  bodies.swap(sorted);
  // Of an edge sent twice, the first kept: a candidate not proven apart before one proven so.
  const auto edge_before = [](const Edge &x, const Edge &y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.candidate < y.candidate);
  };
  const auto edges_head = edges.begin() + static_cast<std::ptrdiff_t>(tidy_edges);
  std::sort(edges_head, edges.end(), edge_before);
  std::inplace_merge(edges.begin(), edges_head, edges.end(), edge_before);
  edges.erase(std::unique(edges.begin(), edges.end(),
                          [](const Edge &x, const Edge &y) { return x.a == y.a && x.b == y.b; }),
              edges.end());
  find_ends(ids, edges, ends);
}

std::uint32_t ExactPieces::at(std::int64_t id) const {
  const auto it = std::lower_bound(ids.begin(), ids.end(), id);
  if (it == ids.end() || *it != id) return static_cast<std::uint32_t>(ids.size());
  return static_cast<std::uint32_t>(it - ids.begin());
}

void read_exact_state(const Particles &p, std::size_t i, double (&s)[kExactState]) {
  const double v[kExactState] = {p.x[i],  p.y[i],  p.z[i],  p.ex[i], p.ey[i], p.ez[i],  p.vx[i],
                                 p.vy[i], p.vz[i], p.wx[i], p.wy[i], p.wz[i], p.grow[i]};
  std::copy(std::begin(v), std::end(v), s);
}

void write_exact_state(Particles &p, std::size_t i, const double (&s)[kExactState]) {
  p.set_position(i, {s[0], s[1], s[2]});
  p.set_axis(i, {s[3], s[4], s[5]});
  p.set_velocity(i, {s[6], s[7], s[8]});
  p.set_angular_velocity(i, {s[9], s[10], s[11]});
  p.grow[i] = s[12];
}

void pack_piece(std::vector<char> &buf, const std::vector<ExactPieces::Body> &bodies,
                const std::vector<ExactPieces::Edge> &edges) {
  pack_array(buf, bodies);
  pack_array(buf, edges);
}

namespace {

void unpack_pieces_from(const std::vector<char> &buf, std::size_t off, ExactPieces &r) {
  while (off < buf.size()) {
    unpack_array(buf, off, r.bodies);
    unpack_array(buf, off, r.edges);
  }
}

}  // namespace

void unpack_pieces(const std::vector<char> &buf, ExactPieces &r) { unpack_pieces_from(buf, 0, r); }

void unpack_message(const std::vector<char> &buf, std::vector<ExactResult> &results,
                    ExactPieces &r) {
  std::size_t off = 0;
  unpack_array(buf, off, results);
  unpack_pieces_from(buf, off, r);
}

ExactClusters exact_clusters(const ExactPieces &r) {
  const auto n = static_cast<std::uint32_t>(r.bodies.size());
  std::vector<std::uint32_t> parent(n), all(n), degree(n, 0);
  std::iota(parent.begin(), parent.end(), 0u);
  std::iota(all.begin(), all.end(), 0u);
  for (const auto &[a, b] : r.ends) {
    ++degree[a], ++degree[b];
    join_sets(parent, a, b);  // bodies are in id order: a cluster's root has its lowest id
  }
  ExactClusters ec;
  ec.cluster_of.assign(n, kNoSet);
  ec.complete.assign(list_sets(parent, all, ec.cluster_of, ec.start, ec.members), 1);
  for (std::uint32_t b = 0; b < n; ++b) {
    const ExactPieces::Body &body = r.bodies[b];
    if (body.degree == kDegreeUnknown || body.degree != degree[b])
      ec.complete[ec.cluster_of[b]] = 0;
  }
  return ec;
}

namespace {

// The pairs inside each cluster of `problem` whose centres are closer than `near`, indexed by
// body as build_neighbor_list does.
void list_near_pairs(const ExactClusters &ec, const Box &box, double near, ExactProblem &problem) {
  const std::size_t n = problem.piece.size();
  const Particles &p = problem.bodies;
  NeighborList &list = problem.list;
  list.pairs.clear();
  const Vec3 inverse = box.inverse_length();
  for (std::uint32_t first = 0; first < n;) {
    const std::uint32_t c = ec.cluster_of[problem.piece[first]];
    const std::uint32_t last = first + ec.size(c);
    for (std::uint32_t a = first; a < last; ++a)
      for (std::uint32_t b = a + 1; b < last; ++b) {
        const Vec3 r = box.minimum_image(p.position(b) - p.position(a), inverse);
        if (norm2(r) >= near * near) continue;
        ListedPair pair;
        pair.first = a;
        pair.second = b;
        list.pairs.push_back(pair);
      }
    first = last;
  }
  list.active = list.bodies = n;
  index_pairs(list);
}

}  // namespace

void exact_problem(const ExactPieces &r, const ExactClusters &ec, const std::vector<char> &take,
                   const Box &box, double near, ExactProblem &problem) {
  std::vector<std::uint32_t> work(r.bodies.size(), kDegreeUnknown);  // piece body -> work
  problem.piece.clear();
  for (std::size_t c = 0; c < ec.count(); ++c) {
    if (!take[c]) continue;
    for (std::uint32_t k = ec.start[c]; k < ec.start[c + 1]; ++k) {
      work[ec.members[k]] = static_cast<std::uint32_t>(problem.piece.size());
      problem.piece.push_back(ec.members[k]);
    }
  }
  const std::size_t n = problem.piece.size();
  Particles &p = problem.bodies;
  p.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ExactPieces::Body &b = r.bodies[problem.piece[k]];
    p.id[k] = b.id;
    write_exact_state(p, k, b.state);
    p.motion_bound[k] = 0.0;
  }
  problem.candidates.clear();
  problem.joins.clear();
  for (std::size_t k = 0; k < r.edges.size(); ++k) {
    const ExactPieces::Edge &e = r.edges[k];
    const std::uint32_t a = work[r.ends[k].first], b = work[r.ends[k].second];
    if (a == kDegreeUnknown) continue;  // a cluster not taken (its edges stay inside it)
    if (e.candidate) {
      Candidate c;
      c.i = a, c.j = b, c.id_i = e.a, c.id_j = e.b;
      c.apart = e.candidate == 2;
      problem.candidates.push_back(c);
    } else {
      problem.joins.emplace_back(a, b);
    }
  }
  list_near_pairs(ec, box, near, problem);
}

ExactResult exact_result(std::int64_t id, std::int64_t label, std::uint32_t size,
                         const FlownBody *flown) {
  ExactResult r;
  r.id = id;
  r.label = label;
  r.size = size;
  if (flown == nullptr) return r;
  r.flown = 1;
  const Vec3 *parts[4] = {&flown->x, &flown->e, &flown->v, &flown->w};
  for (int k = 0; k < 4; ++k) {
    r.state[3 * k] = parts[k]->x;
    r.state[3 * k + 1] = parts[k]->y;
    r.state[3 * k + 2] = parts[k]->z;
  }
  r.overrun = flown->overrun;
  r.collisions = flown->collisions;
  r.virial = flown->virial.raw();
  r.poisoned = flown->virial.poisoned();
  return r;
}

FlownBody flown_body(const ExactResult &r, std::uint32_t body) {
  FlownBody f;
  f.body = body;
  Vec3 *parts[4] = {&f.x, &f.e, &f.v, &f.w};
  for (int k = 0; k < 4; ++k) *parts[k] = {r.state[3 * k], r.state[3 * k + 1], r.state[3 * k + 2]};
  f.overrun = r.overrun;
  f.collisions = r.collisions;
  f.virial = ExactSum::from_raw(r.virial, r.poisoned != 0);
  return f;
}

void pack_results(std::vector<char> &buf, const std::vector<ExactResult> &results) {
  pack_array(buf, results);
}

void unpack_results(const std::vector<char> &buf, std::vector<ExactResult> &out) {
  for (std::size_t off = 0; off < buf.size();) unpack_array(buf, off, out);
}

}  // namespace hardrod
