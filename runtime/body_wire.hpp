// A body on the wire, between ranks (migration, shadows, gathers): its id and the twelve
// doubles of its state (kStateFields, kernels/particles.hpp). The motion bound restarts at 0
// with every rebuild and the motion constants are refreshed on arrival, so neither travels.
// Not the wire of the methods' cluster protocols (runtime/midpoint/cluster_protocol.hpp,
// runtime/exact/exact_protocol.hpp), which send what their solvers read.
#pragma once

#include <fmt/format.h>

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "kernels/particles.hpp"

namespace hardrod {

// A body's count of contacts (or edges) its owner has not told (the body is a shadow where the
// record was made), and "no cluster" / "no slot" in the methods' index lists.
inline constexpr std::uint32_t kDegreeUnknown = 0xffffffffu;

inline constexpr std::size_t kBodyBytes =
    sizeof(std::int64_t) + kStateFields.size() * sizeof(double);

inline void pack_body(std::vector<char> &buf, const Particles &p, std::size_t i) {
  const std::size_t at = buf.size();
  buf.resize(at + kBodyBytes);
  char *out = buf.data() + at;
  std::memcpy(out, &p.id[i], sizeof(std::int64_t));
  out += sizeof(std::int64_t);
  for (BodyField f : kStateFields) {
    std::memcpy(out, &(p.*f)[i], sizeof(double));
    out += sizeof(double);
  }
}

// Into slot i of bodies already sized.
inline void unpack_body_at(const std::vector<char> &buf, std::size_t &off, Particles &p,
                           std::size_t i) {
  if (off + kBodyBytes > buf.size())
    throw std::logic_error(fmt::format("unpack_body: {} bytes left at offset {}, a body needs {}",
                                       buf.size() - off, off, kBodyBytes));
  const char *in = buf.data() + off;
  std::memcpy(&p.id[i], in, sizeof(std::int64_t));
  in += sizeof(std::int64_t);
  for (BodyField f : kStateFields) {
    std::memcpy(&(p.*f)[i], in, sizeof(double));
    in += sizeof(double);
  }
  p.motion_bound[i] = 0.0;
  off += kBodyBytes;
}

// Appended after the bodies already there.
inline void unpack_body(const std::vector<char> &buf, std::size_t &off, Particles &p) {
  const std::size_t i = p.size();
  p.resize(i + 1);
  unpack_body_at(buf, off, p, i);
}

}  // namespace hardrod
