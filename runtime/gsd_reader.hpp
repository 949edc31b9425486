// Reads the GSD file layer (versions 1.x and 2.x: header, index, namelist, chunks; the
// layout is in runtime/gsd_writer.hpp) for starting a run from a GSD frame. Everything is
// checked before use: the magic number, the version, every index entry (type, shape,
// name id, frame order, and that its data lies inside the file); problems throw
// std::runtime_error naming the file and what is wrong.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "runtime/gsd_writer.hpp"

namespace hardrod::gsd {

class Reader {
 public:
  explicit Reader(const std::string &path);

  const std::string &path() const { return path_; }
  const std::string &schema() const { return schema_; }
  std::uint32_t schema_version() const { return schema_version_; }
  std::uint64_t frames() const { return frames_; }

  // The chunk `name` of `frame`, or nullptr if that frame has none.
  const IndexEntry *find(std::uint64_t frame, const std::string &name) const;
  // Its values converted to T, row after row.
  template <typename T>
  std::vector<T> read(const IndexEntry &entry) const;

 private:
  std::vector<unsigned char> bytes(const IndexEntry &entry) const;
  std::string path_, schema_;
  std::uint32_t schema_version_ = 0;
  std::uint64_t frames_ = 0;
  std::map<std::string, std::uint16_t> ids_;
  std::vector<IndexEntry> index_;  // sorted by frame
};

}  // namespace hardrod::gsd
