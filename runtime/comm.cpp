#include "runtime/comm.hpp"

#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

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
  std::atexit(finalize_mpi);
}

constexpr int kExchangeTag = 7001;

}  // namespace

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

std::vector<std::vector<char>> Communicator::exchange(
    const std::string &name, const std::vector<int> &partners,
    const std::vector<std::vector<char>> &outgoing) {
  TrafficCounter &t = traffic_[name];
  std::vector<MPI_Request> requests(partners.size());
  for (std::size_t k = 0; k < partners.size(); ++k) {
    MPI_Isend(outgoing[k].data(), static_cast<int>(outgoing[k].size()), MPI_BYTE, partners[k],
              kExchangeTag, MPI_COMM_WORLD, &requests[k]);
    t.messages += 1;
    t.bytes += static_cast<long long>(outgoing[k].size());
  }
  std::vector<std::vector<char>> incoming(partners.size());
  for (std::size_t k = 0; k < partners.size(); ++k) {
    MPI_Status status;
    MPI_Probe(partners[k], kExchangeTag, MPI_COMM_WORLD, &status);
    int count = 0;
    MPI_Get_count(&status, MPI_BYTE, &count);
    incoming[k].resize(static_cast<std::size_t>(count));
    MPI_Recv(incoming[k].data(), count, MPI_BYTE, partners[k], kExchangeTag, MPI_COMM_WORLD,
             MPI_STATUS_IGNORE);
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  return incoming;
}

std::vector<ExactSum> Communicator::sum(const std::string &name,
                                        const std::vector<ExactSum> &local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  // Each ExactSum travels as its two 64-bit halves plus the poison flag; the halves are
  // added as a 128-bit integer on every rank after an allgather, in rank order (integer
  // addition: the order does not matter anyway).
  const std::size_t m = local.size();
  std::vector<std::int64_t> mine(3 * m);
  for (std::size_t k = 0; k < m; ++k) {
    const auto raw = static_cast<UInt128>(local[k].raw());
    mine[3 * k] = static_cast<std::int64_t>(raw >> 64);
    mine[3 * k + 1] = static_cast<std::int64_t>(static_cast<std::uint64_t>(raw));
    mine[3 * k + 2] = local[k].poisoned() ? 1 : 0;
  }
  std::vector<std::int64_t> all(3 * m * static_cast<std::size_t>(size_));
  MPI_Allgather(mine.data(), static_cast<int>(3 * m), MPI_INT64_T, all.data(),
                static_cast<int>(3 * m), MPI_INT64_T, MPI_COMM_WORLD);
  t.messages += size_ - 1;
  t.bytes += static_cast<long long>(mine.size() * sizeof(std::int64_t)) * (size_ - 1);
  std::vector<ExactSum> out(m);
  for (int r = 0; r < size_; ++r)
    for (std::size_t k = 0; k < m; ++k) {
      const std::size_t base = (static_cast<std::size_t>(r) * m + k) * 3;
      const UInt128 raw = (static_cast<UInt128>(static_cast<std::uint64_t>(all[base])) << 64) |
                          static_cast<std::uint64_t>(all[base + 1]);
      out[k] += ExactSum::from_raw(static_cast<Int128>(raw), all[base + 2] != 0);
    }
  return out;
}

ExactSum Communicator::sum(const std::string &name, const ExactSum &local) {
  return sum(name, std::vector<ExactSum>{local})[0];
}

long long Communicator::sum(const std::string &name, long long local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
  long long out = 0;
  MPI_Allreduce(&local, &out, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  t.messages += size_ - 1;
  t.bytes += static_cast<long long>(sizeof(long long));
  return out;
}

std::vector<double> Communicator::max(const std::string &name, const std::vector<double> &local) {
  if (size_ == 1) return local;
  TrafficCounter &t = traffic_[name];
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

void Communicator::broadcast(const std::string &name, std::vector<char> &data) {
  if (size_ == 1) return;
  TrafficCounter &t = traffic_[name];
  MPI_Bcast(data.data(), static_cast<int>(data.size()), MPI_BYTE, 0, MPI_COMM_WORLD);
  t.messages += 1;
  t.bytes += static_cast<long long>(data.size());
}

}  // namespace hardrod
