#include "kernels/contact_detection.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "kernels/exact/contact_time.hpp"
#include "kernels/exact/gap_bound.hpp"
#include "kernels/lanes.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {

namespace {

// Bodies a and b in canonical orientation by global id (id[i] < id[j]): the same arithmetic
// on every rank.
std::pair<std::uint32_t, std::uint32_t> canonical_pair(const Particles &p, std::uint32_t a,
                                                       std::uint32_t b) {
  return p.id[a] < p.id[b] ? std::pair{a, b} : std::pair{b, a};
}

// A contact's (or candidate's) bodies and ids, i first (canonical_pair).
template <class C>
void name_bodies(const Particles &p, std::uint32_t i, std::uint32_t j, C &c) {
  c.i = i;
  c.j = j;
  c.id_i = p.id[i];
  c.id_j = p.id[j];
}

}  // namespace

bool make_contact(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                  std::uint32_t a, std::uint32_t b, Contact &c, double &distance, double reach) {
  const auto [i, j] = canonical_pair(p, a, b);
  const double h = shape.half_length();
  const Vec3 rij = box.minimum_image(p.position(j) - p.position(i), inverse);
  // Spheres: the centres' distance, the same bits as segment_closest's (its gap is -rij
  // exactly when h = 0), without the segment arithmetic for the many pairs that do not touch.
  if (h == 0.0) {
    distance = std::sqrt(norm2(rij));
    if (!(distance < shape.diameter + reach)) return false;
  }
  const Vec3 ei = p.axis(i), ej = p.axis(j);
  const SegmentClosest sc = segment_closest(rij, ei, h, ej, h);
  distance = std::sqrt(sc.dist2);
  if (!(distance < shape.diameter + reach)) return false;
  name_bodies(p, i, j, c);
  contact_geometry(sc, rij, ei, ej, shape, c);
  c.separation = -rij;
  c.depth = shape.diameter - distance;
  c.impulse = 0.0;
  return true;
}

namespace {

// Lower `target` to `value` if that is smaller. Several threads may lower one body's watch
// in a step; the minimum does not depend on their order.
void lower_to(double &target, double value) {
  std::atomic_ref<double> t(target);
  double now = t.load(std::memory_order_relaxed);
  while (value < now && !t.compare_exchange_weak(now, value, std::memory_order_relaxed)) {
  }
}

// A batch of due pairs measured (due_distances): bodies i and j in canonical orientation
// (canonical_pair), j's centre from i's (minimum image), and their closest points (rods).
constexpr std::size_t kDueBatch = 256;
struct DueBatch {
  std::uint32_t i[kDueBatch], j[kDueBatch];
  double rx[kDueBatch], ry[kDueBatch], rz[kDueBatch];
  double s[kDueBatch], t[kDueBatch], gx[kDueBatch], gy[kDueBatch], gz[kDueBatch];
  double dist2[kDueBatch], distance[kDueBatch];
  // The candidates among them (within reach), which of those the screens proved apart
  // (screen_candidates, refine_candidates), and the rods the first screen left for the second.
  // `beyond`: past the two flights' reach, within the allowance only (spares). The screens'
  // results are as wide as a double: the vector width of a loop is set by its narrowest type,
  // and bytes made it 64 candidates (GCC 12, AVX-512), more than a batch's screens hold, so
  // they ran in the scalar remainder.
  std::uint32_t candidate[kDueBatch];
  std::uint64_t apart[kDueBatch];
  std::uint8_t beyond[kDueBatch];
  std::uint32_t refine[kDueBatch];
  std::uint64_t refined[kDueBatch];
  // What the screens proved (Candidate::proven), and each candidate's distance beyond the two
  // flights' reach: a spare's proof (its points move at most 2 grow each in the step), which
  // the first screen takes where it is the larger (elsewhere it is negative).
  double proven[kDueBatch], refined_proven[kDueBatch], excess[kDueBatch];

  Vec3 r(std::size_t q) const { return {rx[q], ry[q], rz[q]}; }
  SegmentClosest closest(std::size_t q) const {
    return {s[q], t[q], {gx[q], gy[q], gz[q]}, dist2[q]};
  }
};

// The due pairs pairs[due[0, n)] measured as make_contact measures them (canonical
// orientation, minimum image, segment_closest_inline's arithmetic; spheres: the centres'
// distance), in one loop without branches: it runs in vector lanes, with the same operations
// and so the same bits (no contraction: -ffp-contract=off).
template <bool Rods>
void due_distances(const Particles &p, const Box &box, const Vec3 &inverse, double h,
                   const ListedPair *__restrict pairs, const std::uint32_t *__restrict due,
                   std::size_t n, DueBatch &__restrict out) {
  const std::int64_t *__restrict id = p.id.data();
  const double *__restrict x = p.x.data(), *__restrict y = p.y.data(), *__restrict z = p.z.data();
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const Box image = box;
#pragma omp simd
  for (std::size_t q = 0; q < n; ++q) {
    const std::uint32_t a = pairs[due[q]].first, b = pairs[due[q]].second;
    const bool swap = id[b] < id[a];  // canonical_pair
    const std::uint32_t i = swap ? b : a, j = swap ? a : b;
    const Vec3 rij = image.minimum_image({x[j] - x[i], y[j] - y[i], z[j] - z[i]}, inverse);
    out.i[q] = i;
    out.j[q] = j;
    out.rx[q] = rij.x;
    out.ry[q] = rij.y;
    out.rz[q] = rij.z;
    if constexpr (Rods) {
      const SegmentClosest sc =
          segment_closest_inline(rij, {ex[i], ey[i], ez[i]}, h, {ex[j], ey[j], ez[j]}, h);
      out.s[q] = sc.s;
      out.t[q] = sc.t;
      out.gx[q] = sc.gap.x;
      out.gy[q] = sc.gap.y;
      out.gz[q] = sc.gap.z;
      out.dist2[q] = sc.dist2;
      out.distance[q] = std::sqrt(sc.dist2);
    } else {
      out.distance[q] = std::sqrt(norm2(rij));
    }
  }
}

static_assert(kDueBatch % kIndexLanes == 0, "a padded batch stays within its arrays");

// The first screen of apart_in_flight (apart_along_gap, gap_bound.hpp) for the batch's rod
// candidates [0, count), in vector lanes (padded: lanes.hpp): most candidates are proven apart
// here.
void screen_candidates(const Particles &p, double h, double D, double dt, std::size_t count,
                       DueBatch &__restrict batch) {
  count = pad_to_lanes(batch.candidate, count);
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
  const double *__restrict wx = p.wx.data(), *__restrict wy = p.wy.data(),
                           *__restrict wz = p.wz.data();
#pragma omp simd
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t q = batch.candidate[k], i = batch.i[q], j = batch.j[q];
    batch.apart[k] =
        apart_along_gap({ex[i], ey[i], ez[i]}, {vx[i], vy[i], vz[i]}, {wx[i], wy[i], wz[i]},
                        {ex[j], ey[j], ez[j]}, {vx[j], vy[j], vz[j]}, {wx[j], wy[j], wz[j]},
                        batch.r(q), batch.closest(q), h, D, dt, kApartMargin, batch.proven[k]);
    batch.proven[k] = std::max(batch.proven[k], batch.excess[k] - kApartMargin);  // spares
  }
}

// The second screen of apart_in_flight (apart_turning, gap_bound.hpp) for the batch's rod
// candidates the first did not prove apart (spares aside), in vector lanes: a quarter of the
// nematic's.
void refine_candidates(const Particles &p, double h, double D, double dt, std::size_t count,
                       DueBatch &__restrict batch) {
  std::size_t left = 0;
  for (std::size_t k = 0; k < count; ++k) {  // listed without a branch
    batch.refine[left] = static_cast<std::uint32_t>(k);
    left += !batch.apart[k] & !batch.beyond[k];
  }
  const std::size_t padded = pad_to_lanes(batch.refine, left);
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
  const double *__restrict wx = p.wx.data(), *__restrict wy = p.wy.data(),
                           *__restrict wz = p.wz.data();
#pragma omp simd
  for (std::size_t m = 0; m < padded; ++m) {
    const std::uint32_t q = batch.candidate[batch.refine[m]], i = batch.i[q], j = batch.j[q];
    batch.refined[m] = apart_turning(
        {ex[i], ey[i], ez[i]}, {vx[i], vy[i], vz[i]}, {wx[i], wy[i], wz[i]}, {ex[j], ey[j], ez[j]},
        {vx[j], vy[j], vz[j]}, {wx[j], wy[j], wz[j]}, batch.r(q), batch.closest(q), h, D, dt,
        kApartMargin, batch.refined_proven[m]);
  }
  for (std::size_t m = 0; m < left; ++m) {
    batch.apart[batch.refine[m]] = batch.refined[m];
    batch.proven[batch.refine[m]] = batch.refined_proven[m];
  }
}

// apart_in_flight for the batch's sphere candidates [0, count) (spheres_apart), in vector lanes.
void screen_spheres(const Particles &p, double D, double dt, std::size_t count,
                    DueBatch &__restrict batch) {
  count = pad_to_lanes(batch.candidate, count);
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
#pragma omp simd
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t q = batch.candidate[k], i = batch.i[q], j = batch.j[q];
    batch.apart[k] = spheres_apart(batch.r(q), {vx[j] - vx[i], vy[j] - vy[i], vz[j] - vz[i]}, D, dt,
                                   kApartMargin, batch.proven[k]);  // (spares' too: exact)
  }
}

// The exact method's candidate k of a batch (StepAhead, contact_detection.hpp), filled with
// what the clusters read: ids, depth, `spare` (beyond the flights' reach) and `apart` (a spare,
// or proven by the screens: screen_candidates and refine_candidates for rods, screen_spheres).
void exact_candidate(const Particles &p, const Shape &shape, const DueBatch &batch, std::size_t k,
                     Candidate &c) {
  const std::uint32_t q = batch.candidate[k];
  name_bodies(p, batch.i[q], batch.j[q], c);
  c.depth = shape.diameter - batch.distance[q];
  c.spare = batch.beyond[k];
  c.apart = c.spare || batch.apart[k];
  // Rounded to a float and then down by a part in 10^6, over the float's 6e-8: still below.
  c.proven = static_cast<float>(batch.proven[k]) * (1.0f - 1e-6f);
}

// The due pairs pairs[due[0, n)] measured a batch at a time (due_distances), and each pair's
// slack renewed from its distance (bodies at motion bounds summing to `moved`). Those within
// reach become contacts. With `ahead` (the exact method's Candidates, see
// contact_detection.hpp) the bounds already hold the step's whole flight while the bodies are
// still at its start: a candidate is a pair whose gap is below the two flights (plus twice
// the allowance: spares), screened (screen_candidates and refine_candidates, screen_spheres), and
// the slack is renewed for the start. Without (the midpoint method's Contacts), a contact is
// an overlap (rare), measured again by make_contact.
template <class Found>
void measure_due(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                 NeighborList &list, const std::uint32_t *due, std::size_t n,
                 const StepAhead *ahead, std::vector<Found> &found, double &max_depth) {
  const double *bound = p.motion_bound.data();
  const double h = shape.half_length(), D = shape.diameter;
  const double spare = ahead ? 2.0 * ahead->allowance : 0.0;
  thread_local DueBatch batch;
  for (std::size_t from = 0; from < n; from += kDueBatch) {
    const std::size_t m = std::min(kDueBatch, n - from);
    if (h == 0.0)
      due_distances<false>(p, box, inverse, h, list.pairs.data(), due + from, m, batch);
    else
      due_distances<true>(p, box, inverse, h, list.pairs.data(), due + from, m, batch);
    std::size_t candidates = 0;
    for (std::size_t q = 0; q < m; ++q) {
      ListedPair &pair = list.pairs[due[from + q]];
      const double d = batch.distance[q], moved = bound[pair.first] + bound[pair.second];
      const double reach = ahead ? 2.0 * (ahead->grow[pair.first] + ahead->grow[pair.second]) : 0.0;
      pair.recheck_at = slack_below((moved - reach) + (d - D) - kDistanceSafetyMargin);
      batch.candidate[candidates] = static_cast<std::uint32_t>(q);
      batch.beyond[candidates] = !(d < D + reach);
      batch.excess[candidates] = (d - D) - reach;
      candidates += d < D + (reach + spare);  // (a NaN is not)
    }
    if (ahead && h > 0.0) {
      screen_candidates(p, h, D, ahead->dt, candidates, batch);
      refine_candidates(p, h, D, ahead->dt, candidates, batch);
    }
    if (ahead && h == 0.0) screen_spheres(p, D, ahead->dt, candidates, batch);
    for (std::size_t k = 0; k < candidates; ++k) {
      Found &c = found.emplace_back();
      if constexpr (std::is_same_v<Found, Candidate>) {
        exact_candidate(p, shape, batch, k, c);
      } else {
        const std::uint32_t q = batch.candidate[k];
        double again = 0.0;
        make_contact(p, box, inverse, shape, batch.i[q], batch.j[q], c, again);
      }
      max_depth = std::max(max_depth, c.depth);
    }
  }
}

// Pass 1 of the watched detection over bodies [lo, hi): flag the bodies whose motion bound
// (plus `allowance`, StepAhead's) reached their watch (a vector compare) and list them in
// `raised`, skipping eight clear flags at a time. Returns the number of pair ends of the
// listed bodies.
inline long flag_block(long lo, long hi, const double *bound, double allowance, const double *watch,
                       std::uint8_t *flagged, const std::uint32_t *start,
                       std::vector<std::uint32_t> &raised) {
  long ends = 0;
#pragma omp simd
  for (long i = lo; i < hi; ++i) flagged[i] = bound[i] + allowance >= watch[i];
  for (long w = lo; w < hi; w += 8) {
    std::uint64_t word;
    std::memcpy(&word, flagged + w, sizeof word);
    if (word == 0) continue;
    for (long i = w; i < std::min(hi, w + 8); ++i)
      if (flagged[i]) {
        raised.push_back(static_cast<std::uint32_t>(i));
        ends += start[i + 1] - start[i];
      }
  }
  return ends;
}

// Body i's new watch: its smallest allowance over its pairs (+infinity without pairs).
inline double smallest_allowance(const NeighborList &list, std::uint32_t i) {
  double w = std::numeric_limits<double>::infinity();
  for (std::uint32_t a = list.pairs_start[i]; a < list.pairs_start[i + 1]; ++a)
    w = std::min(w, list.pairs[list.pair_index[a]].allowance(i));
  return w;
}

// A contact's place among the threads' blocks, and its ids (the sort key).
struct ContactKey {
  std::uint32_t id_i, id_j, list, at;
};

// Keys in ascending order(key) < largest: a stable radix sort, `other` its scratch. Digits of
// 8 bits below kWideDigits keys (a pass costs its buckets plus two reads of the keys: few
// keys, few buckets), of 11 from there.
constexpr std::size_t kWideDigits = 4096;
template <class Order>
void radix_sort(std::vector<ContactKey> &keys, std::vector<ContactKey> &other, Order &&order,
                std::uint64_t largest) {
  const int bits = keys.size() < kWideDigits ? 8 : 11;
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  other.resize(keys.size());
  std::uint32_t count[std::size_t{1} << 11];
  for (int shift = 0; shift < 64 && (largest >> shift) != 0; shift += bits) {
    std::fill(count, count + mask + 1, 0);
    for (const ContactKey &k : keys) ++count[(order(k) >> shift) & mask];
    std::uint32_t sum = 0;
    for (std::uint64_t d = 0; d <= mask; ++d) sum += std::exchange(count[d], sum);
    for (const ContactKey &k : keys) other[count[(order(k) >> shift) & mask]++] = k;
    keys.swap(other);
  }
}

// The threads' contacts (or candidates) in canonical order, gathered once: the exact method's
// candidates run to thousands per step. The order (id_i, id_j) is that of one integer,
// id_i (max_id + 1) + id_j: sorted by radix from kRadixContacts contacts (a few hundred a step
// in the nematic: the comparison sort's mispredicted branches cost more), by comparison below;
// ids outside [0, 2^31) take the comparison of the pairs.
constexpr std::size_t kRadixContacts = 64;
template <class Found>
void merge_sorted(std::vector<std::vector<Found>> &found, std::vector<Found> &contacts) {
  constexpr std::int64_t kLargestId = std::int64_t{1} << 31;
  thread_local std::vector<ContactKey> keys, other;
  keys.clear();
  std::uint64_t span = 1;
  bool fits = true;
  for (std::uint32_t t = 0; t < found.size(); ++t)
    for (std::uint32_t k = 0; k < found[t].size(); ++k) {
      const Found &c = found[t][k];
      fits = fits && c.id_i >= 0 && c.id_j >= 0 && c.id_i < kLargestId && c.id_j < kLargestId;
      span = std::max(span, static_cast<std::uint64_t>(c.id_j) + 1);
      keys.push_back(
          {static_cast<std::uint32_t>(c.id_i), static_cast<std::uint32_t>(c.id_j), t, k});
    }
  const auto order = [span](const ContactKey &k) { return k.id_i * span + k.id_j; };
  if (fits && keys.size() >= kRadixContacts)
    radix_sort(keys, other, order, span * span);
  else if (fits)
    std::sort(keys.begin(), keys.end(),
              [&](const ContactKey &a, const ContactKey &b) { return order(a) < order(b); });
  else
    std::sort(keys.begin(), keys.end(), [&](const ContactKey &a, const ContactKey &b) {
      return canonical_less(found[a.list][a.at], found[b.list][b.at]);
    });
  contacts.clear();
  contacts.reserve(keys.size());
  for (const ContactKey &key : keys) contacts.push_back(found[key.list][key.at]);
}

// The threads' contacts into `contacts`: in canonical order (merge_sorted) where `ahead` asks
// for it or there is none (the midpoint method's solver needs it), else in the threads' order,
// one thread's by a swap of storage (both keep their capacity for the next step).
template <class Found>
void gather(std::vector<std::vector<Found>> &found, std::vector<Found> &contacts,
            const StepAhead *ahead) {
  if (!ahead || ahead->canonical) {
    merge_sorted(found, contacts);
  } else if (found.size() == 1) {
    std::swap(found[0], contacts);
  } else {
    contacts.clear();
    for (const std::vector<Found> &f : found) contacts.insert(contacts.end(), f.begin(), f.end());
  }
}

}  // namespace

template <class Found>
WatchedTeam<Found>::WatchedTeam(int threads)
    : found(static_cast<std::size_t>(threads)),
      due(static_cast<std::size_t>(threads)),
      ends(static_cast<std::size_t>(threads)),
      tests(static_cast<std::size_t>(threads)),
      depth(static_cast<std::size_t>(threads)) {}

namespace {

// The pairs of the flagged bodies `raised` whose slack is used up (with `spare`, twice
// StepAhead's allowance, added to the bounds), into `due`; a pair of two flagged bodies is
// visited from its first body only.
void list_due_of(const NeighborList &list, const double *bound, double spare,
                 const std::uint8_t *flagged, const std::vector<std::uint32_t> &raised,
                 std::vector<std::uint32_t> &due) {
  const ListedPair *pairs = list.pairs.data();
  const std::uint32_t *start = list.pairs_start.data(), *index = list.pair_index.data();
  // The pairs' records are scattered through the list: ask for all of them first.
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) __builtin_prefetch(&pairs[index[a]], 1);
  due.clear();
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) {
      const ListedPair &pair = pairs[index[a]];
      const std::uint32_t f = pair.first, s = pair.second;
      if (s == i && flagged[f]) continue;  // visited from its first body
      if ((bound[f] + bound[s]) + spare >= pair.recheck_at) due.push_back(index[a]);
    }
}

// Every visited pair's slack split between its bodies, the rest in proportion to the bounds
// so far: bounds grow about linearly, so both bodies then reach their allowances about when
// the pair's slack is used up (evenly while both bounds are 0). An unflagged partner whose
// allowance shrank lowers its watch (an atomic minimum when `shared_watches`).
void split_slacks(NeighborList &list, const double *bound, const std::uint8_t *flagged,
                  const std::vector<std::uint32_t> &raised, bool shared_watches) {
  ListedPair *pairs = list.pairs.data();
  const std::uint32_t *start = list.pairs_start.data(), *index = list.pair_index.data();
  double *watch = list.watch.data();
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) {
      ListedPair &pair = pairs[index[a]];
      const std::uint32_t f = pair.first, s = pair.second;
      if (s == i && flagged[f]) continue;
      const double moved = bound[f] + bound[s];
      const double rest = pair.recheck_at - moved;
      pair.allowance_first = static_cast<float>(
          bound[f] + (moved > 0.0 && rest > 0.0 ? rest * (bound[f] / moved) : 0.5 * rest));
      const std::uint32_t other = f == i ? s : f;
      if (flagged[other]) continue;
      if (shared_watches)
        lower_to(watch[other], pair.allowance(other));
      else  // the same minimum without the atomic's fence
        watch[other] = std::min(watch[other], pair.allowance(other));
    }
}

}  // namespace

template struct WatchedTeam<Contact>;
template struct WatchedTeam<Candidate>;

namespace {

// detect_watched_in_team, for contacts (ahead null) or candidates.
template <class Found>
void watched_in_team(const Particles &p, const Box &box, const Shape &shape, NeighborList &list,
                     WatchedTeam<Found> &shared, const StepAhead *ahead) {
  const long n = static_cast<long>(list.active);
  const double *bound = p.motion_bound.data();
  std::uint8_t *flagged = list.flagged.data();  // n + 8 long (arm_watches)
  const int tid = omp_get_thread_num();
  const int team = omp_get_num_threads();
  const auto [lo, hi] = team_block(n, tid, team);
  std::vector<Found> &mine = shared.found[tid];
  mine.clear();
  std::vector<std::uint32_t> raised;  // this block's flagged bodies
  double max_depth = 0.0;

  const double allowance = ahead ? ahead->allowance : 0.0;
  const long my_ends = flag_block(lo, hi, bound, allowance, list.watch.data(), flagged,
                                  list.pairs_start.data(), raised);
  shared.ends[tid] = my_ends;  // once: the threads' entries share a cache line
#pragma omp barrier
  // Every thread takes the same decision from the same sum (no further barrier).
  long all_ends = 0;
  for (int t = 0; t < team; ++t) all_ends += shared.ends[t];
  if (list.watched_share * all_ends > 2 * static_cast<long>(list.pair_count())) {
    raised.clear();
    if (tid == 0) shared.watching = false;
  }
  // The pairs whose slack is used up, measured; then every visited pair's slack split.
  std::vector<std::uint32_t> &due = shared.due[tid];
  list_due_of(list, bound, 2.0 * allowance, flagged, raised, due);
  measure_due(p, box, box.inverse_length(), shape, list, due.data(), due.size(), ahead, mine,
              max_depth);
  split_slacks(list, bound, flagged, raised, team > 1);
#pragma omp barrier
  for (const std::uint32_t i : raised) list.watch[i] = smallest_allowance(list, i);
  shared.tests[tid] = static_cast<long long>(due.size());
  shared.depth[tid] = max_depth;
}

// How a pass over every pair uses the list's near pairs (NearPairs): not at all (the reference
// pass), or it reads them alone while they hold and makes them again when they do not.
enum class NearUse { none, keep };

template <class Found>
DetectionStats all_pairs(const Particles &p, const Box &box, const Shape &shape, NeighborList &list,
                         std::vector<Found> &contacts, const StepAhead *ahead, NearUse near);

// finish_watched_detection, for contacts (ahead null) or candidates.
template <class Found>
DetectionStats finish_watched(const Particles &p, const Box &box, const Shape &shape,
                              NeighborList &list, WatchedTeam<Found> &shared,
                              std::vector<Found> &contacts, const StepAhead *ahead) {
  if (!shared.watching) {  // too many flagged: the full pass, now and until the next build
    list.watching = false;
    if (list.watched_steps == 0) list.unarmed_builds = kUnarmedBuilds;  // at once: not worth it
    return all_pairs(p, box, shape, list, contacts, ahead, NearUse::keep);
  }
  DetectionStats out;
  out.watched = true;
  ++list.watched_steps;
  for (std::size_t t = 0; t < shared.tests.size(); ++t) {
    out.narrow_phase_tests += shared.tests[t];
    out.max_depth = std::max(out.max_depth, shared.depth[t]);
  }
  gather(shared.found, contacts, ahead);
  return out;
}

// Each thread takes one block of bodies (team_block: the list's body order is cell order,
// so mostly its own pairs too) and makes three passes over it:
//  1. flag the bodies whose motion bound reached their watch (a vector compare), and list
//     them, skipping eight clear flags at a time;
//  2. for each flagged body, its pairs: measure those whose bounds used up the slack, and
//     split every visited pair's remaining slack between its two bodies. A pair of two
//     flagged bodies is visited from its first body only, so each pair has one writer.
//     An unflagged partner whose allowance shrank lowers its watch to it (atomic minimum);
//  3. each flagged body's watch becomes its smallest allowance.
// Pairs of two unflagged bodies are not read: their bounds sum to less than the slack
// (arm_watches). The pairs measured, and so the slacks, are those of a pass over the
// whole list (detect_contacts_all_pairs), for any thread count.
template <class Found>
DetectionStats detect(const Particles &p, const Box &box, const Shape &shape, NeighborList &list,
                      std::vector<Found> &contacts, const StepAhead *ahead) {
  if (!list.watching) return all_pairs(p, box, shape, list, contacts, ahead, NearUse::keep);
  // Threaded exactly when the integration is (particles.hpp).
  const int nthreads = team_threads(static_cast<long>(list.active));
  WatchedTeam<Found> shared(nthreads);
#pragma omp parallel num_threads(nthreads)
  watched_in_team(p, box, shape, list, shared, ahead);
  return finish_watched(p, box, shape, list, shared, contacts, ahead);
}

// Whether the list's near pairs still hold every pair that can be due: made by a pass with
// the same spare, and no body's bound fell since (a build resets them) nor grew by half their
// reach (with 1e-9 for rounding). One pass over the bodies.
bool near_holds(const NearPairs &near, const double *bound, std::size_t n, double spare) {
  if (!near.valid || near.spare != spare || near.base.size() != n) return false;
  const double *base = near.base.data();
  double largest = 0.0, smallest = 0.0, sum = 0.0;
#pragma omp simd reduction(max : largest) reduction(min : smallest) reduction(+ : sum)
  for (std::size_t i = 0; i < n; ++i) {
    const double g = bound[i] - base[i];
    largest = largest > g ? largest : g;
    smallest = smallest < g ? smallest : g;
    sum += g;  // a NaN, which the extremes would drop, stays in the sum
  }
  return std::isfinite(sum) && smallest >= 0.0 && 2.0 * largest + 1e-9 < near.reach;
}

// The near pairs' reach and base for a pass that makes them: kNearSteps times twice the
// largest per-step path (2 grow) of bodies [0, n). False, and the list's near pairs off until
// its next build, where that reach is more than kNearSkinShare of the skin.
bool start_near(NearPairs &near, const Particles &p, std::size_t n, double skin, double spare) {
  double largest = 0.0;
  const double *grow = p.grow.data();
#pragma omp simd reduction(max : largest)
  for (std::size_t i = 0; i < n; ++i) largest = largest > grow[i] ? largest : grow[i];
  near.reach = kNearSteps * 2.0 * (2.0 * largest);
  near.valid = false;
  if (!(near.reach <= kNearSkinShare * skin)) {
    near.off = true;
    return false;
  }
  near.spare = spare;
  near.base.assign(p.motion_bound.begin(), p.motion_bound.begin() + static_cast<long>(n));
  near.valid = true;
  ++near.made;
  return true;
}

// Pairs at[first, last) (without Indexed: the pair indices themselves) tested for due (their
// bounds, plus `spare`, used up the slack: the others cannot have closed their gap yet),
// listed without a branch and measured a batch at a time; with Make, those whose slack left is
// below `reach` are listed in `near` too.
template <bool Make, bool Indexed, class Found>
void pass_pairs(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                NeighborList &list, const std::uint32_t *at, long first, long last,
                const StepAhead *ahead, double spare, double reach,
                std::vector<std::uint32_t> &near, std::vector<Found> &mine, long long &tests,
                double &max_depth) {
  std::uint32_t due[kDueBatch];
  std::size_t n = 0, m = 0;
  if constexpr (Make) near.resize(static_cast<std::size_t>(last - first));
  const ListedPair *pairs = list.pairs.data();
  const double *bound = p.motion_bound.data();
  for (long q = first; q < last; ++q) {
    // (pairs[q] itself without the index: the loop then steps a pointer, as a 32-bit index
    // would not let it)
    const std::uint32_t k = Indexed ? at[q] : static_cast<std::uint32_t>(q);
    const ListedPair &pair = Indexed ? pairs[k] : pairs[q];
    const double moved = (bound[pair.first] + bound[pair.second]) + spare;
    due[n] = k;
    n += moved >= pair.recheck_at;
    if constexpr (Make) {
      near[m] = k;
      m += pair.recheck_at - moved < reach;
    }
    if (n == kDueBatch) {
      measure_due(p, box, inverse, shape, list, due, n, ahead, mine, max_depth);
      tests += static_cast<long long>(n);
      n = 0;
    }
  }
  if (n > 0) {  // the last batch
    measure_due(p, box, inverse, shape, list, due, n, ahead, mine, max_depth);
    tests += static_cast<long long>(n);
  }
  if constexpr (Make) near.resize(m);
}

// Which pairs a pass reads: the near pairs alone (`at`, while they hold), or every pair,
// making the near pairs again (`make_near`) where the list keeps them.
struct PassPlan {
  bool use_near = false, make_near = false;
  const std::uint32_t *at = nullptr;
  long count = 0;
  double spare = 0.0;  // twice StepAhead's allowance
};

PassPlan plan_pass(const Particles &p, NeighborList &list, const StepAhead *ahead, NearUse use) {
  PassPlan plan;
  plan.spare = ahead ? 2.0 * ahead->allowance : 0.0;
  NearPairs &near = list.near;
  const bool keep = use == NearUse::keep && !near.off;
  plan.use_near = keep && near_holds(near, p.motion_bound.data(), list.active, plan.spare);
  plan.make_near =
      keep && !plan.use_near && start_near(near, p, list.active, list.skin, plan.spare);
  plan.at = plan.use_near ? near.index.data() : nullptr;
  plan.count = static_cast<long>(plan.use_near ? near.index.size() : list.pair_count());
  return plan;
}

// The pass over every listed pair (detect_contacts_all_pairs), or, with NearUse::keep, over
// the list's near pairs while they hold (near_holds), made again by the full pass when not.
// The same pairs are due either way, measured in list order.
template <class Found>
DetectionStats all_pairs(const Particles &p, const Box &box, const Shape &shape, NeighborList &list,
                         std::vector<Found> &contacts, const StepAhead *ahead, NearUse use) {
  const int nthreads = omp_get_max_threads();
  // The threads' contacts, their storage kept from step to step (thousands of candidates a
  // step would otherwise be grown from nothing), reached by the team through a reference:
  // inside the parallel region a thread_local name is each thread's own. So too their near
  // pairs.
  thread_local std::vector<std::vector<Found>> storage;
  thread_local std::vector<std::vector<std::uint32_t>> near_storage;
  std::vector<std::vector<Found>> &found = storage;
  std::vector<std::vector<std::uint32_t>> &near_found = near_storage;
  found.resize(static_cast<std::size_t>(nthreads));
  near_found.resize(static_cast<std::size_t>(nthreads));
  for (std::vector<Found> &f : found) f.clear();
  long long tests = 0;
  double max_depth = 0.0;
  const Vec3 inverse = box.inverse_length();
  const PassPlan plan = plan_pass(p, list, ahead, use);
  const double reach = plan.make_near ? list.near.reach : 0.0;
  int team = 1;
#pragma omp parallel reduction(+ : tests) reduction(max : max_depth) \
    if (static_cast<long>(list.active) > kParallelBodies)
  {
    const int tid = omp_get_thread_num();
    if (tid == 0) team = omp_get_num_threads();
    const auto [lo, hi] = team_block(plan.count, tid, omp_get_num_threads());
    auto &mine_near = near_found[static_cast<std::size_t>(tid)];
    const auto pass = [&](auto make, auto indexed) {
      pass_pairs<decltype(make)::value, decltype(indexed)::value>(
          p, box, inverse, shape, list, plan.at, lo, hi, ahead, plan.spare, reach, mine_near,
          found[tid], tests, max_depth);
    };
    if (plan.make_near)
      pass(std::true_type{}, std::false_type{});
    else if (plan.use_near)
      pass(std::false_type{}, std::true_type{});
    else
      pass(std::false_type{}, std::false_type{});
  }
  if (plan.make_near) {  // the threads' blocks in order: list order
    list.near.index.clear();
    for (int t = 0; t < team; ++t)
      list.near.index.insert(list.near.index.end(), near_found[t].begin(), near_found[t].end());
  }
  gather(found, contacts, ahead);
  DetectionStats out{tests, max_depth};
  out.near = plan.use_near;
  return out;
}

}  // namespace

void detect_watched_in_team(const Particles &p, const Box &box, const Shape &shape,
                            NeighborList &list, WatchedDetection &shared) {
  watched_in_team(p, box, shape, list, shared, nullptr);
}

DetectionStats finish_watched_detection(const Particles &p, const Box &box, const Shape &shape,
                                        NeighborList &list, WatchedDetection &shared,
                                        std::vector<Contact> &contacts) {
  return finish_watched(p, box, shape, list, shared, contacts, nullptr);
}

DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Contact> &contacts) {
  return detect(p, box, shape, list, contacts, nullptr);
}

DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Candidate> &candidates,
                               const StepAhead &ahead) {
  return detect(p, box, shape, list, candidates, &ahead);
}

DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Contact> &contacts) {
  return all_pairs(p, box, shape, list, contacts, nullptr, NearUse::none);
}

DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Candidate> &candidates,
                                         const StepAhead &ahead) {
  return all_pairs(p, box, shape, list, candidates, &ahead, NearUse::none);
}

}  // namespace hardrod
