// Contacts (or the exact method's candidates) found by several threads, merged into canonical
// order (id_i, id_j) in one pass: the order every rank and thread count sees (docs/physics.md
// section 7). Thousands a step: a radix sort of their packed ids.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/contact.hpp"

namespace hardrod {

namespace canonical_merge_detail {

// A contact's place among the threads' blocks, and its ids (the sort key).
struct ContactKey {
  std::uint32_t id_i, id_j, list, at;
};

// Keys in ascending order(key) < largest: a stable radix sort, `other` its scratch. Digits of
// 8 bits below kWideDigits keys (a pass costs its buckets plus two reads of the keys: few
// keys, few buckets), of 11 from there.
inline constexpr std::size_t kWideDigits = 4096;
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

// Radix sorting from this many contacts: below it the comparison sort is cheaper.
inline constexpr std::size_t kRadixContacts = 64;

}  // namespace canonical_merge_detail

// The threads' contacts (or candidates) `found` into `contacts` in canonical order. The order
// (id_i, id_j) is that of one integer, id_i (max_id + 1) + id_j: sorted by radix from
// kRadixContacts contacts (the comparison sort's mispredicted branches cost more), by comparison
// below; ids outside [0, 2^31) take the comparison of the pairs.
template <class Found>
void merge_sorted(std::vector<std::vector<Found>> &found, std::vector<Found> &contacts) {
  using namespace canonical_merge_detail;
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

}  // namespace hardrod
