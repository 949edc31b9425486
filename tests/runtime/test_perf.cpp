// perf/: hardware counters say what they measured or why they cannot; the topology is
// described; binding reports what it did.
#include <gtest/gtest.h>

#include <cmath>

#include "perf/counters.hpp"
#include "perf/topology.hpp"

namespace hardrod {
namespace {

TEST(Perf, HardwareCountersMeasureOrSayWhyNot) {
  HardwareCounters c;
  c.start();
  volatile double x = 0.0;
  for (int k = 0; k < 1000000; ++k) x = x + std::sqrt(static_cast<double>(k));
  c.stop();
  if (c.available()) {
    ASSERT_EQ(c.values().size(), 4u);
    EXPECT_EQ(c.values()[0].first, "instructions");
    EXPECT_GT(c.values()[0].second, 1000000);  // the loop alone retires more than that
    EXPECT_NE(c.report().find("IPC"), std::string::npos);
  } else {
    EXPECT_TRUE(c.values().empty());
    EXPECT_NE(c.reason().find("not available"), std::string::npos) << c.reason();
    EXPECT_EQ(c.report(), c.reason());
  }
}

TEST(Perf, TopologyAndBindingDescribeThemselves) {
  const TopologySummary t = describe_topology();
  EXPECT_GE(t.cores, 1);
  EXPECT_GE(t.processing_units, t.cores);
  EXPECT_NE(t.description.find("core(s)"), std::string::npos);
  EXPECT_EQ(bind_threads(false), "thread binding off (--no-bind)");
  EXPECT_NE(thread_placement().find("thread 0 -> PU"), std::string::npos);
}

}  // namespace
}  // namespace hardrod
