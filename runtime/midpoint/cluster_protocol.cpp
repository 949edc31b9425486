#include "runtime/midpoint/cluster_protocol.hpp"

#include <algorithm>
#include <iterator>

#include "runtime/comm.hpp"

namespace hardrod {

namespace {

void pack_vec(std::vector<char> &buf, const Vec3 &v) {
  pack(buf, v.x);
  pack(buf, v.y);
  pack(buf, v.z);
}

Vec3 unpack_vec(const std::vector<char> &buf, std::size_t &off) {
  Vec3 v;
  v.x = unpack<double>(buf, off);
  v.y = unpack<double>(buf, off);
  v.z = unpack<double>(buf, off);
  return v;
}

}  // namespace

void ClusterRecords::tidy() {
  std::sort(bodies.begin(), bodies.end(), [](const Body &a, const Body &b) {
    return a.id != b.id ? a.id < b.id : a.degree < b.degree;
  });
  bodies.erase(std::unique(bodies.begin(), bodies.end(),
                           [](const Body &a, const Body &b) { return a.id == b.id; }),
               bodies.end());
  std::sort(contacts.begin(), contacts.end(), canonical_less);
  contacts.erase(std::unique(contacts.begin(), contacts.end(),
                             [](const Contact &a, const Contact &b) {
                               return a.id_i == b.id_i && a.id_j == b.id_j;
                             }),
                 contacts.end());
  for (Contact &c : contacts) {
    c.i = at(c.id_i);
    c.j = at(c.id_j);
  }
}

std::uint32_t ClusterRecords::at(std::int64_t id) const {
  return static_cast<std::uint32_t>(
      std::lower_bound(bodies.begin(), bodies.end(), id,
                       [](const Body &b, std::int64_t v) { return b.id < v; }) -
      bodies.begin());
}

void read_motion(const Particles &p, std::size_t i, double (&m)[6]) {
  const double v[6] = {p.vx[i], p.vy[i], p.vz[i], p.wx[i], p.wy[i], p.wz[i]};
  std::copy(std::begin(v), std::end(v), m);
}

void write_motion(Particles &p, std::size_t i, const double (&m)[6]) {
  p.set_velocity(i, {m[0], m[1], m[2]});
  p.set_angular_velocity(i, {m[3], m[4], m[5]});
}

void pack_cluster(std::vector<char> &buf, const ClusterRecords::Body *bodies, std::size_t nb,
                  const Contact *const *contacts, std::size_t nc, Wire wire) {
  const bool record = wire == Wire::kRecord;
  pack(buf, static_cast<std::int32_t>(nb));
  for (std::size_t k = 0; k < nb; ++k) {
    pack(buf, bodies[k].id);
    if (record) pack(buf, bodies[k].degree);
    for (double m : bodies[k].motion) pack(buf, m);
  }
  pack(buf, static_cast<std::int32_t>(nc));
  for (std::size_t k = 0; k < nc; ++k) {
    const Contact *c = contacts[k];
    pack(buf, c->id_i);
    pack(buf, c->id_j);
    if (record) {
      for (const Vec3 *v : {&c->normal, &c->arm_i, &c->arm_j, &c->separation}) pack_vec(buf, *v);
      pack(buf, c->depth);
      pack(buf, c->inverse_mass);
    }
    pack(buf, c->impulse);
  }
}

void unpack_clusters(const std::vector<char> &buf, ClusterRecords &r, Wire wire) {
  const bool record = wire == Wire::kRecord;
  for (std::size_t off = 0; off < buf.size();) {
    const auto nb = unpack<std::int32_t>(buf, off);
    for (std::int32_t k = 0; k < nb; ++k) {
      ClusterRecords::Body b;
      b.id = unpack<std::int64_t>(buf, off);
      if (record) b.degree = unpack<std::uint32_t>(buf, off);
      for (double &m : b.motion) m = unpack<double>(buf, off);
      r.bodies.push_back(b);
    }
    const auto nc = unpack<std::int32_t>(buf, off);
    for (std::int32_t k = 0; k < nc; ++k) {
      Contact c;
      c.id_i = unpack<std::int64_t>(buf, off);
      c.id_j = unpack<std::int64_t>(buf, off);
      if (record) {
        for (Vec3 *v : {&c.normal, &c.arm_i, &c.arm_j, &c.separation}) *v = unpack_vec(buf, off);
        c.depth = unpack<double>(buf, off);
        c.inverse_mass = unpack<double>(buf, off);
      }
      c.impulse = unpack<double>(buf, off);
      r.contacts.push_back(c);
    }
  }
}

// Record bodies index the contacts (tidy()), so the kernels' clusters are the records':
// their compact bodies are the record bodies with a contact, in the same order.
RecordClusters cluster_records(const ClusterRecords &r) {
  RecordClusters rc;
  rc.groups = find_clusters(r.contacts);
  rc.cluster_of_body.assign(r.bodies.size(), kDegreeUnknown);
  rc.complete.assign(rc.count(), 1);
  for (std::size_t c = 0; c < rc.count(); ++c)
    for (std::size_t k = 0; k < rc.size(c); ++k) {
      const Contact &ct = r.contacts[rc.contact(c, k)];
      for (std::uint32_t b : {ct.i, ct.j}) {
        rc.cluster_of_body[b] = static_cast<std::uint32_t>(c);
        if (r.bodies[b].degree != rc.groups.degree[rc.groups.find(b)]) rc.complete[c] = 0;
      }
    }
  return rc;
}

std::size_t scratch_problem(const ClusterRecords &r, const RecordClusters &rc,
                            const std::vector<char> &take, const std::vector<char> &owned,
                            Particles &work, std::vector<Contact> &solved,
                            std::vector<std::uint32_t> &slot) {
  slot.assign(r.bodies.size(), kDegreeUnknown);
  std::size_t counted = 0, n = 0;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t b = 0; b < r.bodies.size(); ++b) {
      const std::uint32_t c = rc.cluster_of_body[b];
      if (c == kDegreeUnknown || !take[c] || (owned[b] != 0) != (pass == 0)) continue;
      slot[b] = static_cast<std::uint32_t>(n++);
      if (pass == 0) counted = n;
    }
  work.resize(n);
  for (std::size_t b = 0; b < r.bodies.size(); ++b) {
    if (slot[b] == kDegreeUnknown) continue;
    work.id[slot[b]] = r.bodies[b].id;
    write_motion(work, slot[b], r.bodies[b].motion);
  }
  solved.clear();
  for (const Contact &ct : r.contacts) {  // canonical order
    if (slot[ct.i] == kDegreeUnknown) continue;
    solved.push_back(ct);
    solved.back().i = slot[ct.i];
    solved.back().j = slot[ct.j];
  }
  return counted;
}

}  // namespace hardrod
