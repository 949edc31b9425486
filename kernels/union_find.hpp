// Disjoint sets of indices (union-find with path halving) and the sets listed: the clusters of
// contacts (contact_resolution.cpp), of the exact method's candidates (exact_collisions.cpp)
// and of its pieces across ranks (runtime/exact_protocol.cpp, runtime/exact_ranks.cpp).
// The smaller index is always the root, so the sets and their roots do not depend on the
// order of the joins.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace hardrod {

inline constexpr std::uint32_t kNoSet = std::numeric_limits<std::uint32_t>::max();

inline std::uint32_t set_root(std::vector<std::uint32_t> &parent, std::uint32_t a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

inline void join_sets(std::vector<std::uint32_t> &parent, std::uint32_t a, std::uint32_t b) {
  a = set_root(parent, a);
  b = set_root(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

// The sets of `items` (each in the forest), numbered in the order their first item comes:
// set_of[i] for every item i (set_of must hold kNoSet for the items' roots on entry), and set
// s's items, in the order given, members[start[s] .. start[s + 1]). Returns the set count.
inline std::size_t list_sets(std::vector<std::uint32_t> &parent,
                             const std::vector<std::uint32_t> &items,
                             std::vector<std::uint32_t> &set_of, std::vector<std::uint32_t> &start,
                             std::vector<std::uint32_t> &members) {
  std::vector<std::uint32_t> size;
  for (const std::uint32_t i : items) {
    const std::uint32_t r = set_root(parent, i);
    if (set_of[r] == kNoSet) {
      set_of[r] = static_cast<std::uint32_t>(size.size());
      size.push_back(0);
    }
    set_of[i] = set_of[r];
    ++size[set_of[i]];
  }
  start.assign(size.size() + 1, 0);
  for (std::size_t s = 0; s < size.size(); ++s) start[s + 1] = start[s] + size[s];
  members.resize(items.size());
  std::vector<std::uint32_t> at(start.begin(), start.end() - 1);
  for (const std::uint32_t i : items) members[at[set_of[i]]++] = i;
  return size.size();
}

}  // namespace hardrod
