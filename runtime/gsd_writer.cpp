// The GSD file layer writer: see runtime/gsd_writer.hpp for the layout.
#include "runtime/gsd_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

namespace hardrod::gsd {

namespace {

constexpr std::uint64_t kMagic = 0x65DF65DF65DF65DFull;
constexpr std::size_t kHeaderBytes = 256, kNameBlock = 64;

struct Header {  // the layer's header, 256 bytes on disk in this order
  std::uint64_t magic = kMagic;
  std::uint64_t index_location = 0;
  std::uint64_t index_allocated_entries = 0;
  std::uint64_t namelist_location = 0;
  std::uint64_t namelist_allocated_entries = 0;
  std::uint32_t schema_version = 0;
  std::uint32_t gsd_version = 0;
  std::array<char, 64> application{};
  std::array<char, 64> schema{};
  std::array<char, 80> reserved{};
};
static_assert(sizeof(Header) == kHeaderBytes);

void copy_name(std::array<char, 64> &to, const std::string &from) {
  std::memcpy(to.data(), from.data(), std::min(from.size(), to.size() - 1));  // NUL-ended
}

}  // namespace

std::size_t size_of(Type type) {
  switch (type) {
    case Type::kUint8:
    case Type::kInt8:
      return 1;
    case Type::kUint16:
    case Type::kInt16:
      return 2;
    case Type::kUint32:
    case Type::kInt32:
    case Type::kFloat:
      return 4;
    case Type::kUint64:
    case Type::kInt64:
    case Type::kDouble:
      return 8;
  }
  return 0;
}

std::uint32_t make_version(unsigned major, unsigned minor) { return major << 16 | minor; }

Writer::Writer(const std::string &path, const std::string &application, const std::string &schema,
               std::uint32_t schema_version)
    : path_(path), application_(application), schema_(schema), schema_version_(schema_version) {
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw std::runtime_error(fmt::format("{}: cannot create", path));
  const std::array<char, kHeaderBytes> zeros{};  // the header's place, filled in by finish()
  put(zeros.data(), zeros.size());
}

Writer::~Writer() {
  if (file_ != nullptr) std::fclose(file_);
}

void Writer::put(const void *data, std::size_t bytes) {
  if (bytes > 0 && std::fwrite(data, 1, bytes, file_) != bytes)
    throw std::runtime_error(fmt::format("{}: cannot write (disk full?)", path_));
  end_ += static_cast<std::int64_t>(bytes);
}

void Writer::write_chunk(const std::string &name, Type type, std::uint64_t rows,
                         std::uint32_t columns, const void *data) {
  if (file_ == nullptr) throw std::logic_error(path_ + ": GSD chunk written after finish()");
  if (columns == 0 || name.empty() || name.size() >= kNameBlock)
    throw std::invalid_argument(fmt::format("{}: bad GSD chunk '{}'", path_, name));
  const auto found = std::find(names_.begin(), names_.end(), name);
  const auto id = static_cast<std::size_t>(found - names_.begin());
  if (found == names_.end()) names_.push_back(name);
  IndexEntry entry;
  entry.frame = frame_;
  entry.n = rows;
  entry.m = columns;
  entry.id = static_cast<std::uint16_t>(id);
  entry.type = static_cast<std::uint8_t>(type);
  entry.location = end_;
  put(data, rows * columns * size_of(type));
  index_.push_back(entry);
}

void Writer::finish() {
  // Readers look chunks up by binary search over (frame, id).
  std::stable_sort(index_.begin(), index_.end(), [](const IndexEntry &a, const IndexEntry &b) {
    return a.frame != b.frame ? a.frame < b.frame : a.id < b.id;
  });
  Header header;
  header.index_location = static_cast<std::uint64_t>(end_);
  header.index_allocated_entries = index_.size() + 1;  // an entry at location 0 ends the index
  index_.emplace_back();
  put(index_.data(), index_.size() * sizeof(IndexEntry));
  std::string names;
  for (const std::string &n : names_) names += n + '\0';
  names += '\0';  // an empty name ends the list
  names.resize((names.size() + kNameBlock - 1) / kNameBlock * kNameBlock, '\0');
  header.namelist_location = static_cast<std::uint64_t>(end_);
  header.namelist_allocated_entries = names.size() / kNameBlock;
  put(names.data(), names.size());
  header.schema_version = schema_version_;
  header.gsd_version = make_version(2, 0);
  copy_name(header.application, application_);
  copy_name(header.schema, schema_);
  if (std::fseek(file_, 0, SEEK_SET) != 0 ||
      std::fwrite(&header, 1, sizeof(header), file_) != sizeof(header))
    throw std::runtime_error(fmt::format("{}: cannot write the GSD header", path_));
  const int closed = std::fclose(file_);
  file_ = nullptr;
  if (closed != 0) throw std::runtime_error(fmt::format("{}: cannot write (close failed)", path_));
}

}  // namespace hardrod::gsd
