// The exact method's detection (see the header): the due pairs of the scan measured as
// candidates and screened.
#include "kernels/exact/step_candidates.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "kernels/canonical_merge.hpp"
#include "kernels/due_distances.hpp"
#include "kernels/exact/contact_time.hpp"
#include "kernels/exact/gap_bound.hpp"
#include "kernels/lanes.hpp"

namespace hardrod {

namespace {

// What the screens make of a batch's candidates: the candidates among its pairs (within
// reach), which of those the screens proved apart (screen_candidates, refine_candidates), and
// the rods the first screen left for the second. `beyond`: past the two flights' reach, within
// the allowance only (spares). The screens' results are as wide as a double: the vector width
// of a loop is set by its narrowest type, and bytes made it 64 candidates (GCC 12, AVX-512),
// more than a batch's screens hold, so they ran in the scalar remainder.
// What the screens proved (Candidate::proven), and each candidate's distance beyond the two
// flights' reach: a spare's proof (its points move at most 2 grow each in the step), which the
// first screen takes where it is the larger (elsewhere it is negative).
struct Screens {
  std::uint32_t candidate[kDueBatch];
  std::uint64_t apart[kDueBatch];
  std::uint8_t beyond[kDueBatch];
  std::uint32_t refine[kDueBatch];
  std::uint64_t refined[kDueBatch];
  double proven[kDueBatch], refined_proven[kDueBatch], excess[kDueBatch];
};

static_assert(kDueBatch % kIndexLanes == 0, "a padded batch stays within its arrays");

// The first screen of apart_in_flight (apart_along_gap, gap_bound.hpp) for the batch's rod
// candidates [0, count), in vector lanes (padded: lanes.hpp): most candidates are proven apart
// here.
void screen_candidates(const Particles &p, double h, double D, double dt, std::size_t count,
                       const DueBatch &__restrict batch, Screens &__restrict sc) {
  count = pad_to_lanes(sc.candidate, count);
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
  const double *__restrict wx = p.wx.data(), *__restrict wy = p.wy.data(),
                           *__restrict wz = p.wz.data();
#pragma omp simd
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t q = sc.candidate[k], i = batch.i[q], j = batch.j[q];
    sc.apart[k] =
        apart_along_gap({ex[i], ey[i], ez[i]}, {vx[i], vy[i], vz[i]}, {wx[i], wy[i], wz[i]},
                        {ex[j], ey[j], ez[j]}, {vx[j], vy[j], vz[j]}, {wx[j], wy[j], wz[j]},
                        batch.r(q), batch.closest(q), h, D, dt, kApartMargin, sc.proven[k]);
    sc.proven[k] = std::max(sc.proven[k], sc.excess[k] - kApartMargin);  // spares
  }
}

// The second screen of apart_in_flight (apart_turning, gap_bound.hpp) for the batch's rod
// candidates the first did not prove apart (spares aside), in vector lanes: a quarter of the
// nematic's.
void refine_candidates(const Particles &p, double h, double D, double dt, std::size_t count,
                       const DueBatch &__restrict batch, Screens &__restrict sc) {
  std::size_t left = 0;
  for (std::size_t k = 0; k < count; ++k) {  // listed without a branch
    sc.refine[left] = static_cast<std::uint32_t>(k);
    left += !sc.apart[k] & !sc.beyond[k];
  }
  const std::size_t padded = pad_to_lanes(sc.refine, left);
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
  const double *__restrict wx = p.wx.data(), *__restrict wy = p.wy.data(),
                           *__restrict wz = p.wz.data();
#pragma omp simd
  for (std::size_t m = 0; m < padded; ++m) {
    const std::uint32_t q = sc.candidate[sc.refine[m]], i = batch.i[q], j = batch.j[q];
    sc.refined[m] =
        apart_turning({ex[i], ey[i], ez[i]}, {vx[i], vy[i], vz[i]}, {wx[i], wy[i], wz[i]},
                      {ex[j], ey[j], ez[j]}, {vx[j], vy[j], vz[j]}, {wx[j], wy[j], wz[j]},
                      batch.r(q), batch.closest(q), h, D, dt, kApartMargin, sc.refined_proven[m]);
  }
  for (std::size_t m = 0; m < left; ++m) {
    sc.apart[sc.refine[m]] = sc.refined[m];
    sc.proven[sc.refine[m]] = sc.refined_proven[m];
  }
}

// apart_in_flight for the batch's sphere candidates [0, count) (spheres_apart), in vector lanes.
void screen_spheres(const Particles &p, double D, double dt, std::size_t count,
                    const DueBatch &__restrict batch, Screens &__restrict sc) {
  count = pad_to_lanes(sc.candidate, count);
  const double *__restrict vx = p.vx.data(), *__restrict vy = p.vy.data(),
                           *__restrict vz = p.vz.data();
#pragma omp simd
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t q = sc.candidate[k], i = batch.i[q], j = batch.j[q];
    sc.apart[k] = spheres_apart(batch.r(q), {vx[j] - vx[i], vy[j] - vy[i], vz[j] - vz[i]}, D, dt,
                                kApartMargin, sc.proven[k]);  // (spares' too: exact)
  }
}

// The exact method's candidate k of a batch (StepAhead), filled with
// what the clusters read: ids, depth, `spare` (beyond the flights' reach) and `apart` (a spare,
// or proven by the screens: screen_candidates and refine_candidates for rods, screen_spheres).
void exact_candidate(const Particles &p, const Shape &shape, const DueBatch &batch,
                     const Screens &sc, std::size_t k, Candidate &c) {
  const std::uint32_t q = sc.candidate[k];
  name_bodies(p, batch.i[q], batch.j[q], c);
  c.depth = shape.diameter - batch.distance[q];
  c.spare = sc.beyond[k];
  c.apart = c.spare || sc.apart[k];
  // Rounded to a float and then down by a part in 10^6, over the float's 6e-8: still below.
  c.proven = static_cast<float>(sc.proven[k]) * (1.0f - 1e-6f);
}

// The due pairs as candidates: each pair's slack renewed for the start from its distance (bodies
// at motion bounds summing to `moved`, which already hold the step's flight); a candidate is a
// pair whose gap is below the two flights (plus twice the allowance: spares), screened
// (screen_candidates and refine_candidates, screen_spheres). Each thread's candidates apart,
// merged in canonical order (merge_sorted) or the threads' order.
class CandidateMeasure final : public DueMeasure {
 public:
  CandidateMeasure(const Box &box, const Shape &shape, const StepAhead &ahead)
      : box_(box), inverse_(box.inverse_length()), shape_(shape), ahead_(ahead), found_(storage()) {
    allowance = ahead.allowance;
  }

  void start(int threads) override {
    found_.resize(static_cast<std::size_t>(threads));
    for (std::vector<Candidate> &f : found_) f.clear();
  }

  void measure(int thread, const Particles &p, NeighborList &list, const std::uint32_t *due,
               std::size_t n, double &max_depth) override {
    const double *bound = p.motion_bound.data();
    const double h = shape_.half_length(), D = shape_.diameter;
    const double spare = 2.0 * ahead_.allowance;
    std::vector<Candidate> &found = found_[static_cast<std::size_t>(thread)];
    thread_local DueBatch batch;
    thread_local Screens sc;
    for (std::size_t from = 0; from < n; from += kDueBatch) {
      const std::size_t m = std::min(kDueBatch, n - from);
      measure_distances(p, box_, inverse_, h, list.pairs.data(), due + from, m, batch);
      std::size_t candidates = 0;
      for (std::size_t q = 0; q < m; ++q) {
        ListedPair &pair = list.pairs[due[from + q]];
        const double d = batch.distance[q], moved = bound[pair.first] + bound[pair.second];
        const double reach = 2.0 * (ahead_.grow[pair.first] + ahead_.grow[pair.second]);
        pair.recheck_at = slack_below((moved - reach) + (d - D) - kDistanceSafetyMargin);
        sc.candidate[candidates] = static_cast<std::uint32_t>(q);
        sc.beyond[candidates] = !(d < D + reach);
        sc.excess[candidates] = (d - D) - reach;
        candidates += d < D + (reach + spare);  // (a NaN is not)
      }
      if (h > 0.0) {
        screen_candidates(p, h, D, ahead_.dt, candidates, batch, sc);
        refine_candidates(p, h, D, ahead_.dt, candidates, batch, sc);
      } else {
        screen_spheres(p, D, ahead_.dt, candidates, batch, sc);
      }
      for (std::size_t k = 0; k < candidates; ++k) {
        Candidate &c = found.emplace_back();
        exact_candidate(p, shape_, batch, sc, k, c);
        max_depth = std::max(max_depth, c.depth);
      }
    }
  }

  // The threads' candidates into `candidates`: in canonical order where asked, else in the
  // threads' order, one thread's by a swap of storage (both keep their capacity for the next
  // step).
  void merge(std::vector<Candidate> &candidates) {
    if (ahead_.canonical) {
      merge_sorted(found_, candidates);
    } else if (found_.size() == 1) {
      std::swap(found_[0], candidates);
    } else {
      candidates.clear();
      for (const std::vector<Candidate> &f : found_)
        candidates.insert(candidates.end(), f.begin(), f.end());
    }
  }

 private:
  // The threads' candidates, their storage kept from step to step (thousands of candidates a
  // step would otherwise be grown from nothing).
  static std::vector<std::vector<Candidate>> &storage() {
    thread_local std::vector<std::vector<Candidate>> found;
    return found;
  }
  const Box &box_;
  Vec3 inverse_;
  const Shape &shape_;
  const StepAhead &ahead_;
  std::vector<std::vector<Candidate>> &found_;
};

}  // namespace

DetectionStats detect_candidates(const Particles &p, const Box &box, const Shape &shape,
                                 NeighborList &list, std::vector<Candidate> &candidates,
                                 const StepAhead &ahead) {
  CandidateMeasure measure(box, shape, ahead);
  const DetectionStats out = scan_pairs(p, list, measure);
  measure.merge(candidates);
  return out;
}

DetectionStats detect_candidates_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                           NeighborList &list, std::vector<Candidate> &candidates,
                                           const StepAhead &ahead) {
  CandidateMeasure measure(box, shape, ahead);
  const DetectionStats out = scan_every_pair(p, list, measure);
  measure.merge(candidates);
  return out;
}

}  // namespace hardrod
