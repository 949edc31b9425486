#include "runtime/checkpoint.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <hdf5.h>
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>

#include "runtime/body_wire.hpp"

namespace hardrod {

namespace {

namespace fs = std::filesystem;

constexpr hsize_t kUserBlock = 512;
constexpr const char *kFormat = "hardrod checkpoint";
// The datasets of /bodies besides the ids: three columns each, kStateFields three by three.
const std::array<const char *, 4> kVectors = {"position", "axis", "velocity", "angular_velocity"};
static_assert(3 * kVectors.size() == kStateFields.size());

// 64-bit hash of a byte range, eight bytes at a time (a bit flip anywhere changes it).
std::uint64_t content_hash(const std::vector<char> &bytes, std::size_t from) {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL ^ (bytes.size() - from);
  std::size_t k = from;
  auto mix = [&h](std::uint64_t w) {
    h = (h ^ w) * 0xff51afd7ed558ccdULL;
    h ^= h >> 29;
  };
  for (; k + 8 <= bytes.size(); k += 8) {
    std::uint64_t w;
    std::memcpy(&w, bytes.data() + k, 8);
    mix(w);
  }
  std::uint64_t tail = 0;
  std::memcpy(&tail, bytes.data() + k, bytes.size() - k);
  mix(tail ^ 0x8000000000000000ULL);
  return h;
}

std::vector<char> read_file(const fs::path &path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw CheckpointError(fmt::format("{}: cannot open", path.string()));
  const std::streamsize size = in.tellg();
  std::vector<char> bytes(static_cast<std::size_t>(std::max<std::streamsize>(size, 0)));
  in.seekg(0);
  if (size > 0 && !in.read(bytes.data(), size))
    throw CheckpointError(fmt::format("{}: cannot read its {} bytes", path.string(), size));
  return bytes;
}

void fsync_path(const fs::path &path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// RAII for HDF5 identifiers.
struct Id {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Id(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  ~Id() {
    if (id >= 0 && close) close(id);
  }
  Id(Id &&o) noexcept : id(o.id), close(o.close) { o.id = -1; }
  Id(const Id &) = delete;
  Id &operator=(const Id &) = delete;
  operator hid_t() const { return id; }
};

// ---- writing ------------------------------------------------------------------------------

struct Writer {
  std::string path;
  hid_t transfer = -1;  // collective MPI-IO transfers
  std::string problem;  // first failure on this rank

  void check(herr_t status, const std::string &what) {
    if (status < 0 && problem.empty()) problem = what;
  }

  void string_attribute(hid_t obj, const char *name, const std::string &value) {
    Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type, value.size() + 1);
    Id space(H5Screate(H5S_SCALAR), H5Sclose);
    Id attr(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    check(H5Awrite(attr, type, value.c_str()), std::string("writing attribute ") + name);
  }
  void llong_attribute(hid_t obj, const char *name, long long value) {
    Id space(H5Screate(H5S_SCALAR), H5Sclose);
    Id attr(H5Acreate2(obj, name, H5T_NATIVE_LLONG, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    check(H5Awrite(attr, H5T_NATIVE_LLONG, &value), std::string("writing attribute ") + name);
  }

  // A 1D char dataset; only rank 0 (`writer`) contributes the bytes.
  void text(hid_t parent, const char *name, const std::string &value, hsize_t size, bool writer) {
    Id space(H5Screate_simple(1, &size, nullptr), H5Sclose);
    Id set(H5Dcreate2(parent, name, H5T_NATIVE_CHAR, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
           H5Dclose);
    if (size == 0) return;
    Id memory(H5Screate_simple(1, &size, nullptr), H5Sclose);
    if (!writer) {
      H5Sselect_none(space);
      H5Sselect_none(memory);
    }
    check(H5Dwrite(set, H5T_NATIVE_CHAR, memory, space, transfer, value.data()),
          std::string("writing ") + name);
  }

  // Rows `ids` (global ids, ascending) of an [n][width] dataset, from `data` (ids.size() x
  // width). Runs of consecutive ids are selected as blocks: one per rank, since every rank
  // writes one block of ids (rows_by_id_block). Ids that fall into more than kMaxBlocks runs
  // (not a numbering this program makes) are selected element by element, which HDF5 1.10
  // does faster than hundreds of blocks.
  void rows(hid_t parent, const char *name, hid_t type, hsize_t n, hsize_t width,
            const std::vector<hsize_t> &ids, const void *data) {
    std::array<hsize_t, 2> dims{n, width};
    const int rank = width == 1 ? 1 : 2;
    Id space(H5Screate_simple(rank, dims.data(), nullptr), H5Sclose);
    Id set(H5Dcreate2(parent, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
    const hsize_t elements = ids.size() * width;
    const hsize_t memory_size = std::max<hsize_t>(elements, 1);
    Id memory(H5Screate_simple(1, &memory_size, nullptr), H5Sclose);
    std::vector<std::pair<hsize_t, hsize_t>> runs;  // first id, length
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (!runs.empty() && ids[k] == runs.back().first + runs.back().second)
        ++runs.back().second;
      else
        runs.emplace_back(ids[k], 1);
    }
    if (elements == 0) {
      H5Sselect_none(space);
      H5Sselect_none(memory);
    } else if (runs.size() <= kMaxBlocks) {
      H5S_seloper_t op = H5S_SELECT_SET;
      for (const auto &[first, length] : runs) {
        const std::array<hsize_t, 2> start{first, 0}, count{length, width};
        check(H5Sselect_hyperslab(space, op, start.data(), nullptr, count.data(), nullptr),
              std::string("selecting rows of ") + name);
        op = H5S_SELECT_OR;
      }
    } else {
      std::vector<hsize_t> coords;
      coords.reserve(elements * static_cast<hsize_t>(rank));
      for (hsize_t id : ids)
        for (hsize_t a = 0; a < width; ++a) {
          coords.push_back(id);
          if (rank == 2) coords.push_back(a);
        }
      check(H5Sselect_elements(space, H5S_SELECT_SET, elements, coords.data()),
            std::string("selecting rows of ") + name);
    }
    check(H5Dwrite(set, type, memory, space, transfer, data), std::string("writing ") + name);
  }
  static constexpr std::size_t kMaxBlocks = 64;
};

// Parallel HDF5 writes one file from every rank (each its block of rows, collectively); the
// serial library (the SMPI build: parallel HDF5 cannot run under SMPI) from rank 0 alone, which
// then holds every row.
#ifdef H5_HAVE_PARALLEL
constexpr bool kParallelHdf5 = true;
#else
constexpr bool kParallelHdf5 = false;
#endif

// Writes the file: every rank (parallel HDF5, collective) or rank 0 alone (serial HDF5); the
// problem found, if any, into `problem`.
void write_hdf5(Communicator &comm, const fs::path &tmp, const Particles &owned, std::size_t count,
                const Checkpoint &c, const std::array<hsize_t, 3> &text_sizes,
                std::string &problem) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // one clear message, not HDF5's error stack
  Writer w;
  w.path = tmp.string();
  Id create(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_userblock(create, kUserBlock);
  Id access(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  Id transfer(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
#ifdef H5_HAVE_PARALLEL
  H5Pset_fapl_mpio(access, MPI_COMM_WORLD, MPI_INFO_NULL);
  H5Pset_dxpl_mpio(transfer, H5FD_MPIO_COLLECTIVE);
#endif
  w.transfer = transfer;
  {
    Id file(H5Fcreate(w.path.c_str(), H5F_ACC_TRUNC, create, access), H5Fclose);
    if (file < 0) {
      problem = "creating the file";
      return;
    }
    w.string_attribute(file, "format", kFormat);
    w.llong_attribute(file, "version", kCheckpointVersion);
    w.llong_attribute(file, "step", c.step);
    w.llong_attribute(file, "n", c.n);
    w.string_attribute(file, "state_checksum", c.state_checksum);
    const bool root = comm.is_root();
    w.text(file, "scene", c.scene_toml, text_sizes[0], root);
    w.text(file, "run_state", c.run_state, text_sizes[1], root);
    w.text(file, "root_state", c.root_state, text_sizes[2], root);

    Id bodies(H5Gcreate2(file, "bodies", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    // Rows in id order: HDF5 sorts an unsorted point selection itself, by repeated
    // memmoves (a third of a one-core run's final checkpoint, 0.1 s, for 18432 bodies
    // stored in cell order).
    std::vector<std::size_t> order(count);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return owned.id[a] < owned.id[b]; });
    std::vector<hsize_t> ids(count);
    std::vector<long long> id_values(count);
    for (std::size_t k = 0; k < count; ++k) {
      ids[k] = static_cast<hsize_t>(owned.id[order[k]]);
      id_values[k] = owned.id[order[k]];
    }
    const hsize_t n = static_cast<hsize_t>(c.n);
    w.rows(bodies, "id", H5T_NATIVE_LLONG, n, 1, ids, id_values.data());
    std::vector<double> buffer(3 * count);
    for (std::size_t e = 0; e < kVectors.size(); ++e) {
      for (std::size_t k = 0; k < count; ++k)
        for (std::size_t a = 0; a < 3; ++a)
          buffer[3 * k + a] = (owned.*kStateFields[3 * e + a])[order[k]];
      w.rows(bodies, kVectors[e], H5T_NATIVE_DOUBLE, n, 3, ids, buffer.data());
    }
  }  // collective close: the file is complete on disk
  problem = w.problem;
}

// Collective: throws the first HDF5 problem of any rank, naming the file.
void agree_on_writes(Communicator &comm, const fs::path &tmp, const std::string &problem) {
  const long long failed = comm.sum("checkpoint", problem.empty() ? 0LL : 1LL);
  if (failed > 0)
    throw CheckpointError(fmt::format("{}: HDF5 failed while {}", tmp.string(),
                                      problem.empty() ? "writing on another rank" : problem));
}

// ---- reading ------------------------------------------------------------------------------

struct Reader {
  std::string path;
  hid_t file = -1;

  [[noreturn]] void fail(const std::string &what) const {
    throw CheckpointError(fmt::format("{}: {}", path, what));
  }
  bool has(const char *name) const { return H5Aexists(file, name) > 0; }
  long long llong_attribute(const char *name) const {
    if (!has(name)) fail(fmt::format("attribute {} is missing", name));
    Id attr(H5Aopen(file, name, H5P_DEFAULT), H5Aclose);
    long long v = 0;
    if (H5Aread(attr, H5T_NATIVE_LLONG, &v) < 0)
      fail(fmt::format("cannot read attribute {}", name));
    return v;
  }
  std::string string_attribute(const char *name) const {
    if (!has(name)) fail(fmt::format("attribute {} is missing", name));
    Id attr(H5Aopen(file, name, H5P_DEFAULT), H5Aclose);
    Id type(H5Aget_type(attr), H5Tclose);
    if (H5Tget_class(type) != H5T_STRING) fail(fmt::format("attribute {} is not a string", name));
    const std::size_t size = H5Tget_size(type);
    std::string v(size, '\0');
    if (H5Aread(attr, type, v.data()) < 0) fail(fmt::format("cannot read attribute {}", name));
    return v.substr(0, v.find('\0'));
  }
  Id dataset(const char *name, std::vector<hsize_t> expected) const {
    if (H5Lexists(file, name, H5P_DEFAULT) <= 0) fail(fmt::format("dataset {} is missing", name));
    Id set(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose);
    if (set < 0) fail(fmt::format("cannot open dataset {}", name));
    Id space(H5Dget_space(set), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space);
    std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
    if (!expected.empty() && dims != expected) {
      auto text = [](const std::vector<hsize_t> &d) {
        std::string s = "[";
        for (std::size_t k = 0; k < d.size(); ++k) s += (k ? ", " : "") + std::to_string(d[k]);
        return s + "]";
      };
      fail(fmt::format("dataset {} has shape {}, expected {}", name, text(dims), text(expected)));
    }
    return set;
  }
  std::string text(const char *name) const {
    Id set = dataset(name, {});
    Id space(H5Dget_space(set), H5Sclose);
    const hssize_t size = H5Sget_simple_extent_npoints(space);
    std::string v(static_cast<std::size_t>(std::max<hssize_t>(size, 0)), '\0');
    if (size > 0 && H5Dread(set, H5T_NATIVE_CHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
      fail(fmt::format("cannot read dataset {}", name));
    return v;
  }
  template <typename T>
  std::vector<T> numbers(const char *name, hid_t type, std::vector<hsize_t> dims) const {
    Id set = dataset(name, dims);
    hsize_t total = 1;
    for (hsize_t d : dims) total *= d;
    std::vector<T> v(total);
    if (total > 0 && H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
      fail(fmt::format("cannot read dataset {}", name));
    return v;
  }
};

// The user block: magic line, the file's size and the hash of everything after the block.
std::string user_block(std::uint64_t size, std::uint64_t hash) {
  return fmt::format("{} {}\nbytes {}\nhash {:016x}\n", kFormat, kCheckpointVersion, size, hash);
}

}  // namespace

std::uint64_t body_hash(const Particles &p) {
  std::uint64_t hash = 1469598103934665603ULL;  // FNV-1a 64
  auto feed = [&hash](const void *data, std::size_t bytes) {
    const auto *c = static_cast<const unsigned char *>(data);
    for (std::size_t k = 0; k < bytes; ++k) {
      hash ^= c[k];
      hash *= 1099511628211ULL;
    }
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    feed(&p.id[i], sizeof(std::int64_t));
    for (BodyField f : kStateFields) feed(&(p.*f)[i], sizeof(double));
  }
  return hash;
}

namespace {

// The rows each writing rank writes, as one block of ids: every body goes to the rank whose
// block [r n / W, (r + 1) n / W) of the W = `writers` first ranks holds its id (one message to
// every other writer, at a checkpoint only; W = 1: every row to rank 0). HDF5 then selects one
// hyperslab per rank. Rows as they fall after migration are hundreds of short runs per rank,
// which HDF5 selects slowly either way (element by element or as blocks).
Particles rows_by_id_block(Communicator &comm, const Particles &owned, std::size_t count,
                           long long n, int writers) {
  const int ranks = comm.size(), me = comm.rank();
  std::vector<std::vector<char>> out(static_cast<std::size_t>(ranks));
  for (std::size_t i = 0; i < count; ++i) {
    const long long id = owned.id[i];
    const int r = id >= 0 && id < n ? static_cast<int>(id * writers / n) : std::min(me, writers - 1);
    pack_body(out[static_cast<std::size_t>(r)], owned, i);
  }
  // Every rank sends to the writers, a writer hears from every rank.
  std::vector<int> partners;
  std::vector<std::vector<char>> outgoing;
  for (int r = 0; r < ranks; ++r)
    if (r != me && (r < writers || me < writers)) {
      partners.push_back(r);
      outgoing.push_back(std::move(out[static_cast<std::size_t>(r)]));
    }
  std::vector<std::vector<char>> incoming = comm.exchange("checkpoint", partners, outgoing);
  incoming.push_back(std::move(out[static_cast<std::size_t>(comm.rank())]));
  std::size_t rows = 0;
  for (const auto &buf : incoming) rows += buf.size() / kBodyBytes;
  Particles mine;
  mine.resize(rows);
  std::size_t k = 0;
  for (const auto &buf : incoming)
    for (std::size_t off = 0; off < buf.size(); ++k) unpack_body_at(buf, off, mine, k);
  return mine;
}

// The bytes a checkpoint takes, generously: its rows, its texts and HDF5's own structures.
std::uintmax_t checkpoint_bytes(long long n, const std::array<hsize_t, 3> &text_sizes) {
  constexpr std::uintmax_t kOverhead = 256 * 1024;
  return kOverhead + static_cast<std::uintmax_t>(n) * (1 + 3 * kVectors.size()) * 8 +
         text_sizes[0] + text_sizes[1] + text_sizes[2];
}

// "no space left on device: ..." when `dir` has less room than `needed`, else empty: HDF5
// over MPI-IO reports a full disk only as a failed write.
std::string space_problem(const fs::path &dir, std::uintmax_t needed) {
  std::error_code ec;
  const fs::space_info space = fs::space(dir, ec);
  if (ec || space.available >= needed) return {};
  return fmt::format("{}: {} bytes free in {}, a checkpoint needs about {}", std::strerror(ENOSPC),
                     space.available, dir.string(), needed);
}

// Rank 0's problem, if any, thrown on every rank.
void agree_on(Communicator &comm, const std::string &problem) {
  if (comm.sum("checkpoint", problem.empty() ? 0LL : 1LL) > 0)
    throw CheckpointError(problem.empty() ? "checkpoint failed on rank 0" : problem);
}

// Rank 0's seal of the written file: the file's size and the hash of everything after the user
// block go into the user block, which HDF5 leaves to us; then the previous checkpoint is kept
// aside and the new one takes its name, each step synced. Returns the problem ("" if none), the
// temporary file then removed.
std::string seal_and_rename(const fs::path &dir, const fs::path &tmp, const fs::path &final_path) {
  try {
    std::vector<char> bytes = read_file(tmp);
    const std::string block = user_block(bytes.size(), content_hash(bytes, kUserBlock));
    {
      std::fstream out(tmp, std::ios::in | std::ios::out | std::ios::binary);
      out.seekp(0);
      out.write(block.data(), static_cast<std::streamsize>(block.size()));
      if (!out) throw CheckpointError(fmt::format("{}: cannot seal the user block", tmp.string()));
    }
    fsync_path(tmp, false);
    std::error_code ec;
    if (fs::exists(final_path)) fs::rename(final_path, dir / kPreviousCheckpointFile, ec);
    if (ec)
      throw CheckpointError(fmt::format("{}: cannot keep the previous checkpoint ({})",
                                        final_path.string(), ec.message()));
    fs::rename(tmp, final_path, ec);
    if (ec)
      throw CheckpointError(fmt::format("{}: cannot rename to {} ({})", tmp.string(),
                                        final_path.string(), ec.message()));
    fsync_path(dir, true);
    return {};
  } catch (const std::exception &e) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return e.what();
  }
}

// The sizes of rank 0's texts (scene, run state, root state), on every rank: every rank must
// create the same datasets (or parallel HDF5 deadlocks in H5Fclose), and rank 0's are written.
std::array<hsize_t, 3> text_sizes(Communicator &comm, const Checkpoint &contents) {
  std::array<hsize_t, 3> sizes{};
  const std::array<const std::string *, 3> texts = {&contents.scene_toml, &contents.run_state,
                                                    &contents.root_state};
  for (std::size_t k = 0; k < texts.size(); ++k)
    sizes[k] = static_cast<hsize_t>(
        comm.sum("checkpoint", comm.is_root() ? static_cast<long long>(texts[k]->size()) : 0LL));
  return sizes;
}

}  // namespace

void write_checkpoint(Communicator &comm, const fs::path &dir, const Particles &owned,
                      std::size_t count, const Checkpoint &contents) {
  const fs::path final_path = dir / kCheckpointFile;
  const fs::path tmp = dir / (std::string(kCheckpointFile) + ".tmp");
  const std::array<hsize_t, 3> sizes = text_sizes(comm, contents);
  // A full disk is found before anything is written, and named when a write fails; either
  // way no partial checkpoint.h5.tmp stays and the previous checkpoints are untouched.
  const std::uintmax_t needed = checkpoint_bytes(contents.n, sizes);
  const std::string where = fmt::format("checkpoint at step {} not written", contents.step);
  if (comm.is_root()) {
    const std::string full = space_problem(dir, needed);
    agree_on(comm, full.empty() ? "" : where + ": " + full);
  } else {
    agree_on(comm, "");
  }
  try {
    std::string problem;
    if (comm.size() == 1) {
      write_hdf5(comm, tmp, owned, count, contents, sizes, problem);
    } else {
      const int writers = kParallelHdf5 ? comm.size() : 1;
      const Particles rows = rows_by_id_block(comm, owned, count, contents.n, writers);
      if (comm.rank() < writers) write_hdf5(comm, tmp, rows, rows.size(), contents, sizes, problem);
    }
    agree_on_writes(comm, tmp, problem);
  } catch (const CheckpointError &e) {
    if (!comm.is_root()) throw;
    std::error_code ec;
    fs::remove(tmp, ec);
    const std::string full = space_problem(dir, needed);
    throw CheckpointError(
        fmt::format("{}: {}", where, full.empty() ? std::string(e.what()) : full));
  }
  agree_on(comm, comm.is_root() ? seal_and_rename(dir, tmp, final_path) : std::string());
}

namespace {

// The user block's seal: the format line, the version, and the size and content hash that
// seal_and_rename wrote, against the file as it is.
void check_seal(Reader &r, const fs::path &path) {
  const std::vector<char> bytes = read_file(path);
  if (bytes.size() < kUserBlock)
    r.fail(
        fmt::format("truncated: {} bytes, not even the {}-byte header", bytes.size(), kUserBlock));
  const std::string block(bytes.begin(), bytes.begin() + kUserBlock);
  unsigned long long size = 0, hash = 0;
  int version = 0;
  const std::string magic = std::string(kFormat) + " %d\nbytes %llu\nhash %llx\n";
  if (std::sscanf(block.c_str(), magic.c_str(), &version, &size, &hash) != 3)
    r.fail("not a hardrod checkpoint (header line missing or damaged)");
  if (version != kCheckpointVersion)
    r.fail(fmt::format("checkpoint version {}, this hardrod reads version {}", version,
                       kCheckpointVersion));
  if (size != bytes.size())
    r.fail(fmt::format("truncated or extended: {} bytes on disk, {} written", bytes.size(), size));
  const std::uint64_t actual = content_hash(bytes, kUserBlock);
  if (actual != hash)
    r.fail(fmt::format("corrupted: content hash {:016x}, written {:016x}", actual, hash));
}

// The bodies, checked: ids 0..n-1 in order, every number finite, unit axes, and their hash
// against the checkpoint's state_checksum.
void read_bodies(Reader &r, Checkpoint &c) {
  const hsize_t n = static_cast<hsize_t>(c.n);
  const auto ids = r.numbers<long long>("bodies/id", H5T_NATIVE_LLONG, {n});
  for (std::size_t k = 0; k < ids.size(); ++k)
    if (ids[k] != static_cast<long long>(k))
      r.fail(fmt::format("bodies/id[{}] = {}: bodies must be stored in id order 0..{}", k, ids[k],
                         c.n - 1));
  Particles &p = c.bodies;
  p.resize(static_cast<std::size_t>(c.n));
  for (std::size_t k = 0; k < ids.size(); ++k) p.id[k] = ids[k];
  for (std::size_t e = 0; e < kVectors.size(); ++e) {
    const std::string name = std::string("bodies/") + kVectors[e];
    const auto v = r.numbers<double>(name.c_str(), H5T_NATIVE_DOUBLE, {n, 3});
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t a = 0; a < 3; ++a) {
        const double x = v[3 * i + a];
        if (!std::isfinite(x)) r.fail(fmt::format("{}[{}][{}] = {}: not finite", name, i, a, x));
        (p.*kStateFields[3 * e + a])[i] = x;
      }
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double norm = std::sqrt(p.ex[i] * p.ex[i] + p.ey[i] * p.ey[i] + p.ez[i] * p.ez[i]);
    if (std::fabs(norm - 1.0) > 1e-6)
      r.fail(fmt::format("bodies/axis[{}] has length {}: axes must be unit vectors", i, norm));
  }
  const std::string actual = fmt::format("{:016x}", body_hash(p));
  if (actual != c.state_checksum)
    r.fail(fmt::format("bodies hash to {}, the checkpoint says {}", actual, c.state_checksum));
}

}  // namespace

Checkpoint read_checkpoint(const fs::path &path) {
  Reader r;
  r.path = path.string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) r.fail("no such checkpoint file");
  check_seal(r, path);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // our messages, not HDF5's error stack
  Id file(H5Fopen(r.path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (file < 0) r.fail("not a readable HDF5 file");
  r.file = file;
  if (r.string_attribute("format") != kFormat)
    r.fail("attribute format is not \"hardrod checkpoint\"");
  const long long version = r.llong_attribute("version");
  if (version != kCheckpointVersion)
    r.fail(fmt::format("checkpoint version {}, this hardrod reads version {}", version,
                       kCheckpointVersion));
  Checkpoint c;
  c.step = r.llong_attribute("step");
  c.n = r.llong_attribute("n");
  if (c.step < 0) r.fail(fmt::format("step = {}: must be >= 0", c.step));
  if (c.n < 1) r.fail(fmt::format("n = {}: must be >= 1", c.n));
  c.state_checksum = r.string_attribute("state_checksum");
  c.scene_toml = r.text("scene");
  c.run_state = r.text("run_state");
  c.root_state = r.text("root_state");
  read_bodies(r, c);
  return c;
}

}  // namespace hardrod
