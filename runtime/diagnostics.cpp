// Diagnostics of the distributed state, collective over ranks: the bodies gathered in id
// order, the state checksum that pins a trajectory bit for bit, and the check that every
// body is owned once and every shadow is a copy of its owner's body. Not for the hot path:
// each of them moves every body.
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "runtime/body_wire.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/system.hpp"

namespace hardrod {

namespace {

// Rank 0's check of all ranks' owned ids: 0..n-1 once each. Empty when they are.
std::string ownership_problem(const std::vector<char> &all, long long n) {
  std::vector<std::int64_t> ids;
  for (std::size_t off = 0; off < all.size();) ids.push_back(unpack<std::int64_t>(all, off));
  std::sort(ids.begin(), ids.end());
  if (static_cast<long long>(ids.size()) != n)
    return fmt::format("{} bodies owned in total, expected {}", ids.size(), n);
  for (std::size_t k = 0; k < ids.size(); ++k)
    if (ids[k] != static_cast<std::int64_t>(k))
      return fmt::format(
          "id {} is {}", ids[k],
          k > 0 && ids[k] == ids[k - 1] ? "owned twice" : "out of place (a body was lost)");
  return {};
}

}  // namespace

void System::verify_bodies() {
  // Owned bodies: gathered at rank 0, which checks 0..n-1 once each.
  std::vector<char> mine;
  for (std::size_t i = 0; i < owned_; ++i) pack(mine, particles_.id[i]);
  const std::vector<char> all = comm_.gather("verify", mine);
  std::string problem = comm_.is_root() ? ownership_problem(all, scene_.n) : std::string();
  // Shadows: each rank checks its copies against their owners' bodies, gathered at rank 0
  // and sent back to everyone as one block (debug only: this moves every body).
  std::vector<char> owned_state;
  for (std::size_t i = 0; i < owned_; ++i) pack_body(owned_state, particles_, i);
  std::vector<char> everything = comm_.gather("verify", owned_state);
  long long size = static_cast<long long>(everything.size());
  size = comm_.sum("verify", comm_.is_root() ? size : 0LL);
  everything.resize(static_cast<std::size_t>(size));
  comm_.broadcast("verify", everything);
  Particles reference;
  for (std::size_t off = 0; off < everything.size();) unpack_body(everything, off, reference);
  std::unordered_map<std::int64_t, std::size_t> where;
  for (std::size_t i = 0; i < reference.size(); ++i) where[reference.id[i]] = i;
  long long mismatches = 0;
  for (std::size_t i = owned_; i < advanced(); ++i) {  // the shadows this rank advances
    const auto it = where.find(particles_.id[i]);
    if (it == where.end()) {
      ++mismatches;
      continue;
    }
    const std::size_t k = it->second;
    for (BodyField f : kStateFields)  // bit for bit (0.0 and -0.0 differ)
      if (std::memcmp(&(particles_.*f)[i], &(reference.*f)[k], sizeof(double)) != 0) {
        ++mismatches;
        break;
      }
  }
  mismatches = comm_.sum("verify", mismatches);
  if (problem.empty() && mismatches > 0)
    problem = fmt::format("{} shadow copies differ from their owners' bodies", mismatches);
  const long long failed = comm_.sum("verify", problem.empty() ? 0LL : 1LL);
  if (failed > 0)
    throw std::logic_error(fmt::format("step {}: body bookkeeping broken: {}", step_,
                                       problem.empty() ? "(see rank 0)" : problem));
}

Particles System::gather_bodies() {
  std::vector<char> mine;
  mine.reserve(owned_ * kBodyBytes);
  for (std::size_t i = 0; i < owned_; ++i) pack_body(mine, particles_, i);
  const std::vector<char> all = comm_.gather("gather", mine);
  Particles bodies;
  if (!comm_.is_root()) return bodies;
  const std::size_t total = all.size() / kBodyBytes;
  bodies.resize(total);
  for (std::size_t k = 0, off = 0; k < total; ++k) unpack_body_at(all, off, bodies, k);
  // Ids are 0..n-1 (every start numbers the bodies so): body k goes to row id[k], no sort.
  // Anything else (not a permutation) is sorted, as a check costs one pass.
  std::vector<std::uint32_t> order(total, 0);
  std::vector<char> seen(total, 0);
  bool dense = true;
  for (std::size_t k = 0; k < total && dense; ++k) {
    const std::int64_t id = bodies.id[k];
    dense = id >= 0 && static_cast<std::size_t>(id) < total && !seen[static_cast<std::size_t>(id)];
    if (dense) {
      seen[static_cast<std::size_t>(id)] = 1;
      order[static_cast<std::size_t>(id)] = static_cast<std::uint32_t>(k);
    }
  }
  if (!dense) {
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(),
              [&](std::uint32_t a, std::uint32_t b) { return bodies.id[a] < bodies.id[b]; });
  }
  bodies.permute(order);
  return bodies;
}

std::string System::state_checksum() {
  const Particles p = gather_bodies();
  const std::uint64_t hash = body_hash(p);
  // Rank 0 computed it; a sum with zeros from the other ranks gives it to everyone.
  ExactSum h;
  if (comm_.is_root()) h = ExactSum::from_raw(static_cast<Int128>(hash), false);
  const ExactSum all = comm_.sum("checksum", h);
  return fmt::format("{:016x}", static_cast<std::uint64_t>(all.raw()));
}

}  // namespace hardrod
