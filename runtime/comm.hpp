// The only code that talks to MPI (docs/style.md habit 1). A Communicator holds the world and
// the 3D Cartesian process grid, and counts every message and byte it moves, per named
// exchange, so summary.json can report communication per step per rank. Global sums go
// through ExactSum (integer arithmetic), so every reduction has the same bits for any
// rank count. One rank is the same code with no partners.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "kernels/exact_sum.hpp"

namespace hardrod {

// Bytes and messages of one named communication step.
struct TrafficCounter {
  long long messages = 0;
  long long bytes = 0;
  double seconds = 0.0;  // in the calls, waiting included
};

// MPI_Finalize, if MPI was started and is not finalized yet: main's last call (SMPI requires
// every rank to finalize before its main returns; a process exit finalizes too, through
// std::atexit, where main does not return).
void finalize_communication();

class Communicator {
 public:
  // Initialises MPI on first use (and finalises it at exit), so tests and the program
  // can use it with or without mpirun.
  Communicator();

  // The MPI library's own description (MPI_Get_library_version), first line.
  static std::string library_version();

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }
  // Ends every rank of the job at once (MPI_Abort) with `code`: for an error that only some
  // ranks may have met, where waiting for the others would hang.
  [[noreturn]] void abort(int code) const;

  // Process grid: explicit dims (product must equal size) or 0s for MPI_Dims_create.
  std::array<int, 3> make_grid(std::array<int, 3> dims) const;

  // Sparse exchange with a fixed set of partner ranks: one message to and from every
  // partner (possibly empty). `outgoing[k]` goes to partners[k]; returns what each
  // partner sent, in partner order.
  std::vector<std::vector<char>> exchange(const std::string &name, const std::vector<int> &partners,
                                          const std::vector<std::vector<char>> &outgoing);

  // Reductions, all counted under their own names.
  ExactSum sum(const std::string &name, const ExactSum &local);
  std::vector<ExactSum> sum(const std::string &name, const std::vector<ExactSum> &local);
  long long sum(const std::string &name, long long local);
  std::vector<double> max(const std::string &name, const std::vector<double> &local);
  // Gather variable-size byte blocks at rank 0 (in rank order); others get an empty result.
  std::vector<char> gather(const std::string &name, const std::vector<char> &local);
  // Every rank waits for all (MPI_Barrier), counted under `name`.
  void barrier(const std::string &name);
  // Rank 0's bytes to everyone (the buffer must already have rank 0's size everywhere).
  void broadcast(const std::string &name, std::vector<char> &data);

  const std::map<std::string, TrafficCounter> &traffic() const { return traffic_; }

 private:
  int rank_ = 0;
  int size_ = 1;
  std::map<std::string, TrafficCounter> traffic_;
};

// A list of ranks (partners to send to), ascending and each once.
inline void sort_unique(std::vector<int> &ranks) {
  std::sort(ranks.begin(), ranks.end());
  ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
}

// Little helpers to pack plain values into byte buffers.
template <typename T>
void pack(std::vector<char> &buf, const T &value) {
  const auto *p = reinterpret_cast<const char *>(&value);
  buf.insert(buf.end(), p, p + sizeof(T));
}
template <typename T>
T unpack(const std::vector<char> &buf, std::size_t &offset) {
  T value;
  std::copy(buf.begin() + static_cast<long>(offset),
            buf.begin() + static_cast<long>(offset + sizeof(T)), reinterpret_cast<char *>(&value));
  offset += sizeof(T);
  return value;
}

}  // namespace hardrod
