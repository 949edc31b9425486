#include "perf/counters.hpp"

#include <fmt/format.h>
#include <linux/perf_event.h>
#include <omp.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace hardrod {

namespace {

struct Event {
  const char *name;
  std::uint64_t config;
};
constexpr std::array<Event, 4> kEvents = {{{"instructions", PERF_COUNT_HW_INSTRUCTIONS},
                                           {"cycles", PERF_COUNT_HW_CPU_CYCLES},
                                           {"cache_references", PERF_COUNT_HW_CACHE_REFERENCES},
                                           {"cache_misses", PERF_COUNT_HW_CACHE_MISSES}}};

int open_counter(std::uint64_t config) {
  perf_event_attr attr;
  std::memset(&attr, 0, sizeof(attr));
  attr.type = PERF_TYPE_HARDWARE;
  attr.size = sizeof(attr);
  attr.config = config;
  attr.disabled = 1;
  attr.exclude_kernel = 1;
  attr.exclude_hv = 1;
  return static_cast<int>(syscall(SYS_perf_event_open, &attr, 0, -1, -1, 0));
}

}  // namespace

void HardwareCounters::start() {
  const int threads = omp_get_max_threads();
  fds_.assign(static_cast<std::size_t>(threads), std::vector<int>(kEvents.size(), -1));
  std::vector<int> errors(static_cast<std::size_t>(threads), 0);
#pragma omp parallel num_threads(threads)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    for (std::size_t e = 0; e < kEvents.size(); ++e) {
      fds_[t][e] = open_counter(kEvents[e].config);
      if (fds_[t][e] < 0) {
        errors[t] = errno;
      } else {
        ioctl(fds_[t][e], PERF_EVENT_IOC_RESET, 0);
        ioctl(fds_[t][e], PERF_EVENT_IOC_ENABLE, 0);
      }
    }
  }
  available_ = true;
  for (std::size_t t = 0; t < fds_.size(); ++t)
    for (std::size_t e = 0; e < kEvents.size(); ++e)
      if (fds_[t][e] < 0) available_ = false;
  if (!available_) {
    int err = 0;
    for (int e : errors) err = err ? err : e;
    reason_ = fmt::format("hardware counters not available (perf_event_open: {})",
                          std::strerror(err ? err : ENOSYS));
    for (auto &row : fds_)
      for (int fd : row)
        if (fd >= 0) close(fd);
    fds_.clear();
  } else {
    reason_.clear();
  }
}

void HardwareCounters::stop() {
  if (!available_) return;
  std::vector<std::vector<long long>> counts(fds_.size(),
                                             std::vector<long long>(kEvents.size(), 0));
#pragma omp parallel num_threads(static_cast <int>(fds_.size()))
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    for (std::size_t e = 0; e < kEvents.size(); ++e) {
      ioctl(fds_[t][e], PERF_EVENT_IOC_DISABLE, 0);
      long long value = 0;
      if (read(fds_[t][e], &value, sizeof(value)) == sizeof(value)) counts[t][e] = value;
      close(fds_[t][e]);
    }
  }
  values_.clear();
  for (std::size_t e = 0; e < kEvents.size(); ++e) {
    long long sum = 0;
    for (const auto &row : counts) sum += row[e];
    values_.emplace_back(kEvents[e].name, sum);
  }
  fds_.clear();
}

std::string HardwareCounters::report() const {
  if (!available_) return reason_;
  std::string out;
  for (const auto &[name, value] : values_)
    out += fmt::format("{}{} {}", out.empty() ? "" : ", ", name, value);
  if (values_.size() >= 2 && values_[1].second > 0)
    out += fmt::format(", IPC {:.2f}", static_cast<double>(values_[0].second) / values_[1].second);
  return out;
}

}  // namespace hardrod
