// The GSD file layer reader: see runtime/gsd_reader.hpp.
#include "runtime/gsd_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace hardrod::gsd {

namespace {

struct RawHeader {  // as on disk (runtime/gsd_writer.cpp)
  std::uint64_t magic, index_location, index_allocated_entries, namelist_location,
      namelist_allocated_entries;
  std::uint32_t schema_version, gsd_version;
  char application[64], schema[64], reserved[80];
};
static_assert(sizeof(RawHeader) == 256);

std::uint64_t file_size(std::ifstream &in) {
  in.seekg(0, std::ios::end);
  return static_cast<std::uint64_t>(in.tellg());
}

void read_at(std::ifstream &in, std::uint64_t at, void *to, std::uint64_t bytes,
             const std::string &path, const char *what) {
  in.seekg(static_cast<std::streamoff>(at));
  in.read(static_cast<char *>(to), static_cast<std::streamsize>(bytes));
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read the GSD {}", path, what));
}

template <typename From, typename T>
void convert(const unsigned char *raw, std::size_t count, std::vector<T> &out) {
  for (std::size_t k = 0; k < count; ++k) {
    From v;
    std::memcpy(&v, raw + k * sizeof(From), sizeof(From));
    out[k] = static_cast<T>(v);
  }
}

}  // namespace

Reader::Reader(const std::string &path) : path_(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot open", path));
  const std::uint64_t size = file_size(in);
  RawHeader h;
  if (size < sizeof(h))
    throw std::runtime_error(fmt::format("{}: not a GSD file (too short)", path));
  read_at(in, 0, &h, sizeof(h), path, "header");
  if (h.magic != 0x65DF65DF65DF65DFull)
    throw std::runtime_error(fmt::format("{}: not a GSD file (no GSD magic number)", path));
  const unsigned major = h.gsd_version >> 16;
  if (major < 1 || major > 2)
    throw std::runtime_error(
        fmt::format("{}: GSD file layer version {}.{}: only 1.x and 2.x are read", path, major,
                    h.gsd_version & 0xffff));
  h.schema[63] = '\0';
  schema_ = h.schema;
  schema_version_ = h.schema_version;
  const std::uint64_t names_bytes = h.namelist_allocated_entries * 64;
  if (h.namelist_location > size || names_bytes > size - h.namelist_location ||
      h.index_location > size || h.index_allocated_entries > (size - h.index_location) / 32)
    throw std::runtime_error(
        fmt::format("{}: corrupt GSD file (index or namelist beyond the end of the file)", path));
  // Names end with a NUL each (2.x packs them, 1.x pads each to 64 bytes); an empty one ends
  // the list.
  std::string names(names_bytes, '\0');
  read_at(in, h.namelist_location, names.data(), names_bytes, path, "namelist");
  std::uint16_t next = 0;
  for (std::size_t at = 0; at < names.size();) {
    const std::size_t end = std::min(names.find('\0', at), names.size());
    if (end > at)
      ids_.emplace(names.substr(at, end - at), next++);
    else if (major >= 2)
      break;
    at = major >= 2 ? end + 1 : (at / 64 + 1) * 64;
  }
  std::vector<IndexEntry> all(h.index_allocated_entries);
  read_at(in, h.index_location, all.data(), all.size() * sizeof(IndexEntry), path, "index");
  for (const IndexEntry &e : all) {
    if (e.location == 0) break;
    const std::size_t bytes = size_of(static_cast<Type>(e.type));
    const bool inside = bytes > 0 && e.location > 0 && e.m > 0 && e.n <= (size / bytes) / e.m &&
                        static_cast<std::uint64_t>(e.location) <= size - e.n * e.m * bytes;
    if (!inside || e.id >= next || e.flags != 0 ||
        (!index_.empty() && e.frame < index_.back().frame))
      throw std::runtime_error(fmt::format(
          "{}: corrupt GSD file (index entry {}: frame {}, type {}, {} x {} at byte {})", path,
          index_.size(), e.frame, e.type, e.n, e.m, e.location));
    index_.push_back(e);
  }
  frames_ = index_.empty() ? 0 : index_.back().frame + 1;
}

const IndexEntry *Reader::find(std::uint64_t frame, const std::string &name) const {
  const auto id = ids_.find(name);
  if (id == ids_.end()) return nullptr;
  auto [first, last] =
      std::equal_range(index_.begin(), index_.end(), IndexEntry{.frame = frame},
                       [](const IndexEntry &a, const IndexEntry &b) { return a.frame < b.frame; });
  for (auto e = first; e != last; ++e)
    if (e->id == id->second) return &*e;
  return nullptr;
}

std::vector<unsigned char> Reader::bytes(const IndexEntry &e) const {
  std::ifstream in(path_, std::ios::binary);
  std::vector<unsigned char> raw(e.n * e.m * size_of(static_cast<Type>(e.type)));
  read_at(in, static_cast<std::uint64_t>(e.location), raw.data(), raw.size(), path_, "chunk");
  return raw;
}

template <typename T>
std::vector<T> Reader::read(const IndexEntry &e) const {
  const std::vector<unsigned char> raw = bytes(e);
  const std::size_t count = e.n * e.m;
  std::vector<T> out(count);
  switch (static_cast<Type>(e.type)) {
    case Type::kUint8:
      convert<std::uint8_t>(raw.data(), count, out);
      break;
    case Type::kUint16:
      convert<std::uint16_t>(raw.data(), count, out);
      break;
    case Type::kUint32:
      convert<std::uint32_t>(raw.data(), count, out);
      break;
    case Type::kUint64:
      convert<std::uint64_t>(raw.data(), count, out);
      break;
    case Type::kInt8:
      convert<std::int8_t>(raw.data(), count, out);
      break;
    case Type::kInt16:
      convert<std::int16_t>(raw.data(), count, out);
      break;
    case Type::kInt32:
      convert<std::int32_t>(raw.data(), count, out);
      break;
    case Type::kInt64:
      convert<std::int64_t>(raw.data(), count, out);
      break;
    case Type::kFloat:
      convert<float>(raw.data(), count, out);
      break;
    case Type::kDouble:
      convert<double>(raw.data(), count, out);
      break;
  }
  return out;
}

template std::vector<double> Reader::read<double>(const IndexEntry &) const;
template std::vector<std::uint64_t> Reader::read<std::uint64_t>(const IndexEntry &) const;

}  // namespace hardrod::gsd
