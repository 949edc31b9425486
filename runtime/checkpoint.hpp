// Checkpoints: everything a run needs to continue exactly, in one HDF5 file.
//
// Layout (HDF5 with a 512-byte user block in front):
//   user block: "hardrod checkpoint 1\nbytes <size>\nhash <16 hex>\n" — the size of the whole
//     file and a 64-bit hash of every byte after the user block. A reader checks both before
//     HDF5 sees the file, so a truncated or bit-flipped checkpoint is rejected with a clear
//     message (and never crashes the HDF5 library).
//   /            attributes format = "hardrod checkpoint", version, step, n, state_checksum
//   /scene       the scene, canonical TOML (chars)
//   /run_state   the run's accumulators, JSON (chars; identical on every rank)
//   /root_state  rank 0's extra state (the Frank accumulator), JSON (chars; may be empty)
//   /bodies/{id[n], position[n][3], axis[n][3], velocity[n][3], angular_velocity[n][3]}
//                in global-id order, so any rank or thread count can read it back.
// Writing is collective (parallel HDF5 over MPI-IO; each rank writes its owned rows) into
// `checkpoint.h5.tmp`, which rank 0 then fsyncs and renames over `checkpoint.h5` after the
// previous one was renamed to `checkpoint.prev.h5`: a complete checkpoint exists at every
// moment, even when the job is killed during the write.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "kernels/particles.hpp"
#include "runtime/comm.hpp"

namespace hardrod {

inline constexpr int kCheckpointVersion = 1;
inline constexpr const char *kCheckpointFile = "checkpoint.h5";
inline constexpr const char *kPreviousCheckpointFile = "checkpoint.prev.h5";

struct Checkpoint {
  long long step = 0;
  long long n = 0;
  std::string state_checksum;  // of the bodies, as System::state_checksum()
  std::string scene_toml;
  std::string run_state;   // JSON
  std::string root_state;  // JSON or empty
  Particles bodies;        // read_checkpoint: all n in id order
};

// A checkpoint that cannot be used: every problem found, each naming the file and what.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// FNV-1a over ids, positions, axes, velocities and angular velocities of `p` (id order).
std::uint64_t body_hash(const Particles &p);

// Collective over `comm`. `owned` holds this rank's owned bodies in [0, count); step, n and
// state_checksum must be the same on every rank; the texts are rank 0's. Writes
// dir/checkpoint.h5 atomically as described above. Throws CheckpointError.
void write_checkpoint(Communicator &comm, const std::filesystem::path &dir, const Particles &owned,
                      std::size_t count, const Checkpoint &contents);

// Reads and checks a checkpoint (user block, version, shapes, ids, finite values, unit axes,
// state checksum). Independent of MPI: every rank may read it. Throws CheckpointError.
Checkpoint read_checkpoint(const std::filesystem::path &path);

}  // namespace hardrod
