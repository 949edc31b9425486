// The midpoint method's detection (see the header): the due pairs of the scan measured as
// contacts, and the narrow phase the methods share (make_contact).
#include "kernels/contact_detection.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "kernels/canonical_merge.hpp"
#include "kernels/due_distances.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {

bool make_contact(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                  std::uint32_t a, std::uint32_t b, Contact &c, double &distance, double reach) {
  // Canonical orientation by global id (id[i] < id[j]): the same arithmetic on every rank.
  const auto [i, j] = p.id[a] < p.id[b] ? std::pair{a, b} : std::pair{b, a};
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

// The due pairs as the midpoint method's contacts: each pair's slack renewed from its distance
// (bodies at motion bounds summing to `moved`), and an overlap (rare) measured again by
// make_contact. Each thread's contacts apart, merged in canonical order (merge_sorted).
class ContactMeasure final : public DueMeasure {
 public:
  ContactMeasure(const Box &box, const Shape &shape)
      : box_(box), inverse_(box.inverse_length()), shape_(shape), found_(storage()) {}

  void start(int threads) override {
    found_.resize(static_cast<std::size_t>(threads));
    for (std::vector<Contact> &f : found_) f.clear();
  }

  void measure(int thread, const Particles &p, NeighborList &list, const std::uint32_t *due,
               std::size_t n, double &max_depth) override {
    const double *bound = p.motion_bound.data();
    const double h = shape_.half_length(), D = shape_.diameter;
    std::vector<Contact> &found = found_[static_cast<std::size_t>(thread)];
    thread_local DueBatch batch;
    for (std::size_t from = 0; from < n; from += kDueBatch) {
      const std::size_t m = std::min(kDueBatch, n - from);
      measure_distances(p, box_, inverse_, h, list.pairs.data(), due + from, m, batch);
      for (std::size_t q = 0; q < m; ++q) {
        ListedPair &pair = list.pairs[due[from + q]];
        const double d = batch.distance[q], moved = bound[pair.first] + bound[pair.second];
        pair.recheck_at = slack_below(moved + (d - D) - kDistanceSafetyMargin);
        if (!(d < D)) continue;  // (a NaN is not)
        Contact &c = found.emplace_back();
        double again = 0.0;
        make_contact(p, box_, inverse_, shape_, batch.i[q], batch.j[q], c, again);
        max_depth = std::max(max_depth, c.depth);
      }
    }
  }

  void merge(std::vector<Contact> &contacts) { merge_sorted(found_, contacts); }

 private:
  // The threads' contacts, their storage kept from step to step.
  static std::vector<std::vector<Contact>> &storage() {
    thread_local std::vector<std::vector<Contact>> found;
    return found;
  }
  const Box &box_;
  Vec3 inverse_;
  const Shape &shape_;
  std::vector<std::vector<Contact>> &found_;
};

}  // namespace

struct WatchedDetection::Measure {
  Measure(const Box &box, const Shape &shape) : contacts(box, shape) {}
  ContactMeasure contacts;
};

WatchedDetection::WatchedDetection(int threads, const Box &box, const Shape &shape)
    : team(threads), measure(std::make_unique<Measure>(box, shape)) {
  measure->contacts.start(threads);
}

WatchedDetection::~WatchedDetection() = default;

void detect_watched_in_team(const Particles &p, NeighborList &list, WatchedDetection &shared) {
  scan_watched_in_team(p, list, shared.team, shared.measure->contacts);
}

DetectionStats finish_watched_detection(const Particles &p, NeighborList &list,
                                        WatchedDetection &shared, std::vector<Contact> &contacts) {
  const DetectionStats out = finish_watched_scan(p, list, shared.team, shared.measure->contacts);
  shared.measure->contacts.merge(contacts);
  return out;
}

DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Contact> &contacts) {
  ContactMeasure measure(box, shape);
  const DetectionStats out = scan_pairs(p, list, measure);
  measure.merge(contacts);
  return out;
}

DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Contact> &contacts) {
  ContactMeasure measure(box, shape);
  const DetectionStats out = scan_every_pair(p, list, measure);
  measure.merge(contacts);
  return out;
}

}  // namespace hardrod
