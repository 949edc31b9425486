// The GSD file layer (version 2.0, as gsd 2.x and HOOMD-blue read it), written without the
// GSD library (Debian has none): a 256-byte header, the data chunks, then the index (one
// 32-byte entry per chunk: frame, N, location, M, name id, type, flags; sorted by frame and
// name id) and the namelist (the names, each ended by a NUL, in id order). The header is
// written last, so a file whose writing failed has no valid header and no reader takes it.
// Little-endian hosts only (the GSD layer stores native byte order; readers expect little).
// The reader of the same layer is runtime/gsd_reader.hpp; the HOOMD schema on top of both
// is runtime/hoomd_gsd.hpp.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace hardrod::gsd {

// The layer's type ids.
enum class Type : std::uint8_t {
  kUint8 = 1,
  kUint16 = 2,
  kUint32 = 3,
  kUint64 = 4,
  kInt8 = 5,
  kInt16 = 6,
  kInt32 = 7,
  kInt64 = 8,
  kFloat = 9,
  kDouble = 10,
};
std::size_t size_of(Type type);  // bytes per value; 0 for an id outside the layer's list

template <typename T>
constexpr Type type_of();
template <>
constexpr Type type_of<std::uint8_t>() {
  return Type::kUint8;
}
template <>
constexpr Type type_of<std::uint32_t>() {
  return Type::kUint32;
}
template <>
constexpr Type type_of<std::uint64_t>() {
  return Type::kUint64;
}
template <>
constexpr Type type_of<std::int8_t>() {
  return Type::kInt8;
}
template <>
constexpr Type type_of<std::int32_t>() {
  return Type::kInt32;
}
template <>
constexpr Type type_of<float>() {
  return Type::kFloat;
}
template <>
constexpr Type type_of<double>() {
  return Type::kDouble;
}

struct IndexEntry {  // the layer's index entry, 32 bytes on disk in this order
  std::uint64_t frame = 0;
  std::uint64_t n = 0;
  std::int64_t location = 0;
  std::uint32_t m = 0;
  std::uint16_t id = 0;
  std::uint8_t type = 0;
  std::uint8_t flags = 0;
};
static_assert(sizeof(IndexEntry) == 32);

std::uint32_t make_version(unsigned major, unsigned minor);

class Writer {
 public:
  // Creates (truncates) `path`. Throws std::runtime_error naming the path on failure.
  Writer(const std::string &path, const std::string &application, const std::string &schema,
         std::uint32_t schema_version);
  ~Writer();  // closes without finishing: the file has no header then
  Writer(const Writer &) = delete;
  Writer &operator=(const Writer &) = delete;

  // One chunk of the current frame: `rows` x `columns` values of `type` at `data`.
  void write_chunk(const std::string &name, Type type, std::uint64_t rows, std::uint32_t columns,
                   const void *data);
  template <typename T>
  void write_chunk(const std::string &name, const std::vector<T> &values, std::uint32_t columns) {
    write_chunk(name, type_of<T>(), values.size() / columns, columns, values.data());
  }
  void end_frame() { ++frame_; }
  // Writes the index, the namelist and the header, and closes. Throws naming the path.
  void finish();

 private:
  void put(const void *data, std::size_t bytes);
  std::FILE *file_ = nullptr;
  std::string path_, application_, schema_;
  std::uint32_t schema_version_;
  std::uint64_t frame_ = 0;
  std::int64_t end_ = 0;  // bytes written so far
  std::vector<IndexEntry> index_;
  std::vector<std::string> names_;
};

}  // namespace hardrod::gsd
