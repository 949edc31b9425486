#include "runtime/comm.hpp"

#include <mpi.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <stdexcept>

#include "perf/clock.hpp"

namespace hardrod {

namespace {

void finalize_mpi() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) MPI_Finalize();
}

void ensure_mpi() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) return;
  int provided = 0;
  // Only the main thread calls MPI; OpenMP threads work between calls.
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
#ifndef HARDROD_SMPI  // under SMPI the simulation is over at exit: main finalizes
  std::atexit(finalize_mpi);
#endif
}

constexpr int kExchangeTag = 7001;

// The time a named call takes, waiting included, on the program's clock (the simulated time
// under SMPI).
class Timed {
 public:
  explicit Timed(TrafficCounter &t)
      : t_(t), start_(ProgramClock::now_before_communication(reinterpret_cast<std::uintptr_t>(&t))) {}
  ~Timed() { t_.seconds += seconds_between(start_, ProgramClock::now_after_communication()); }
  Timed(const Timed &) = delete;
  Timed &operator=(const Timed &) = delete;

 private:
  TrafficCounter &t_;
  ProgramClock::time_point start_;
};

}  // namespace

void finalize_communication() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) finalize_mpi();
}

void Communicator::abort(int code) const {
  std::fflush(stdout);
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);  // not reached: MPI_Abort does not return
}

Communicator::Communicator() {
  ensure_mpi();
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

std::string Communicator::library_version() {
  char text[MPI_MAX_LIBRARY_VERSION_STRING];
  int length = 0;
  MPI_Get_library_version(text, &length);
  std::string s(text, static_cast<std::size_t>(length));
  const auto end = s.find_first_of("\n,");
  return s.substr(0, end);
}

std::array<int, 3> Communicator::make_grid(std::array<int, 3> dims) const {
  if (dims[0] * dims[1] * dims[2] == size_) return dims;
  int d[3] = {dims[0], dims[1], dims[2]};
  MPI_Dims_create(size_, 3, d);
  return {d[0], d[1], d[2]};
}

// Each message's first kEagerBytes travel at once, headed by the message's size, into a receive
// posted beforehand; a longer message's rest follows as a second message, received once the
// head has said how long it is. So a step's small messages (the contacts, the pieces) take one
// latency and no probing (an MPI_Probe polls, which a simulated network, SMPI, models poorly),
// and the rebuilds' large ones two.
std::vector<std::vector<char>> Communicator::exchange(
    const std::string &name, const std::vector<int> &partners,
    const std::vector<std::vector<char>> &outgoing) {
  constexpr std::size_t kEagerBytes = 4096, kHead = sizeof(std::uint64_t);
  constexpr int kRestTag = kExchangeTag + 1;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  const std::size_t np = partners.size();
  std::vector<std::vector<char>> heads_in(np, std::vector<char>(kEagerBytes)), heads_out(np);
  std::vector<MPI_Request> receives(np), sends;
  sends.reserve(2 * np);
  for (std::size_t k = 0; k < np; ++k)
    MPI_Irecv(heads_in[k].data(), static_cast<int>(kEagerBytes), MPI_BYTE, partners[k],
              kExchangeTag, MPI_COMM_WORLD, &receives[k]);
  for (std::size_t k = 0; k < np; ++k) {
    const std::vector<char> &m = outgoing[k];
    const std::uint64_t size = m.size();
    const std::size_t first = std::min<std::size_t>(m.size(), kEagerBytes - kHead);
    heads_out[k].resize(kHead + first);
    std::memcpy(heads_out[k].data(), &size, kHead);
    std::copy(m.begin(), m.begin() + static_cast<long>(first), heads_out[k].begin() + kHead);
    sends.emplace_back();
    MPI_Isend(heads_out[k].data(), static_cast<int>(heads_out[k].size()), MPI_BYTE, partners[k],
              kExchangeTag, MPI_COMM_WORLD, &sends.back());
    if (m.size() > first) {
      sends.emplace_back();
      MPI_Isend(m.data() + first, static_cast<int>(m.size() - first), MPI_BYTE, partners[k],
                kRestTag, MPI_COMM_WORLD, &sends.back());
      t.messages += 1;
    }
    t.messages += 1;
    t.bytes += static_cast<long long>(m.size());
  }
  MPI_Waitall(static_cast<int>(np), receives.data(), MPI_STATUSES_IGNORE);
  std::vector<std::vector<char>> incoming(np);
  std::vector<MPI_Request> rests;
  for (std::size_t k = 0; k < np; ++k) {
    std::uint64_t size = 0;
    std::memcpy(&size, heads_in[k].data(), kHead);
    const std::size_t first = std::min<std::size_t>(size, kEagerBytes - kHead);
    incoming[k].resize(size);
    std::copy(heads_in[k].begin() + kHead, heads_in[k].begin() + static_cast<long>(kHead + first),
              incoming[k].begin());
    if (size > first) {
      rests.emplace_back();
      MPI_Irecv(incoming[k].data() + first, static_cast<int>(size - first), MPI_BYTE, partners[k],
                kRestTag, MPI_COMM_WORLD, &rests.back());
    }
  }
  MPI_Waitall(static_cast<int>(rests.size()), rests.data(), MPI_STATUSES_IGNORE);
  MPI_Waitall(static_cast<int>(sends.size()), sends.data(), MPI_STATUSES_IGNORE);
  return incoming;
}

namespace {

// An ExactSum on the wire: its 128-bit accumulator as two 64-bit halves and its poison flag.
struct WireSum {
  std::uint64_t hi, lo, poisoned;
};

// The reduction of ExactSums: 128-bit integer addition (wrapping, as unsigned) and the poison
// flags' or. Associative and commutative, so any reduction tree gives the same bits, in
// log2(ranks) steps.
void add_wire_sums(void *in, void *inout, int *len, MPI_Datatype *) {
  const auto *a = static_cast<const WireSum *>(in);
  auto *b = static_cast<WireSum *>(inout);
  for (int k = 0; k < *len; ++k) {
    const UInt128 x = (static_cast<UInt128>(a[k].hi) << 64) | a[k].lo;
    const UInt128 y = (static_cast<UInt128>(b[k].hi) << 64) | b[k].lo;
    const UInt128 z = x + y;
    b[k].hi = static_cast<std::uint64_t>(z >> 64);
    b[k].lo = static_cast<std::uint64_t>(z);
    b[k].poisoned = a[k].poisoned | b[k].poisoned;
  }
}

}  // namespace

std::vector<ExactSum> Communicator::sum(const std::string &name,
                                        const std::vector<ExactSum> &local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  const std::size_t m = local.size();
  std::vector<WireSum> mine(m), all(m);
  for (std::size_t k = 0; k < m; ++k) {
    const auto raw = static_cast<UInt128>(local[k].raw());
    mine[k] = {static_cast<std::uint64_t>(raw >> 64), static_cast<std::uint64_t>(raw),
               local[k].poisoned() ? 1u : 0u};
  }
  MPI_Datatype type;
  MPI_Type_contiguous(3, MPI_UINT64_T, &type);
  MPI_Type_commit(&type);
  MPI_Op op;
  MPI_Op_create(add_wire_sums, 1, &op);
  MPI_Allreduce(mine.data(), all.data(), static_cast<int>(m), type, op, MPI_COMM_WORLD);
  MPI_Op_free(&op);
  MPI_Type_free(&type);
  t.messages += 1;
  t.bytes += static_cast<long long>(m * sizeof(WireSum));
  std::vector<ExactSum> out(m);
  for (std::size_t k = 0; k < m; ++k) {
    const UInt128 raw = (static_cast<UInt128>(all[k].hi) << 64) | all[k].lo;
    out[k] = ExactSum::from_raw(static_cast<Int128>(raw), all[k].poisoned != 0);
  }
  return out;
}

ExactSum Communicator::sum(const std::string &name, const ExactSum &local) {
  return sum(name, std::vector<ExactSum>{local})[0];
}

long long Communicator::sum(const std::string &name, long long local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  long long out = 0;
  MPI_Allreduce(&local, &out, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  t.messages += size_ - 1;
  t.bytes += static_cast<long long>(sizeof(long long));
  return out;
}

std::vector<double> Communicator::max(const std::string &name, const std::vector<double> &local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  std::vector<double> out(local.size());
  MPI_Allreduce(local.data(), out.data(), static_cast<int>(local.size()), MPI_DOUBLE, MPI_MAX,
                MPI_COMM_WORLD);
  t.messages += 1;
  t.bytes += static_cast<long long>(local.size() * sizeof(double));
  return out;
}

std::vector<char> Communicator::gather(const std::string &name, const std::vector<char> &local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  int mine = static_cast<int>(local.size());
  std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
  MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<char> all;
  if (rank_ == 0) {
    int total = 0;
    for (int r = 0; r < size_; ++r) {
      displs[r] = total;
      total += counts[r];
    }
    all.resize(static_cast<std::size_t>(total));
  }
  MPI_Gatherv(local.data(), mine, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, 0,
              MPI_COMM_WORLD);
  t.messages += 2;
  t.bytes += mine;
  return all;
}

void Communicator::barrier(const std::string &name) {
  if (size_ == 1) return;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  MPI_Barrier(MPI_COMM_WORLD);
  t.messages += 1;
}

void Communicator::broadcast(const std::string &name, std::vector<char> &data) {
  if (size_ == 1) return;
  TrafficCounter &t = traffic_[name];
  const Timed timed(t);
  MPI_Bcast(data.data(), static_cast<int>(data.size()), MPI_BYTE, 0, MPI_COMM_WORLD);
  t.messages += 1;
  t.bytes += static_cast<long long>(data.size());
}

}  // namespace hardrod
