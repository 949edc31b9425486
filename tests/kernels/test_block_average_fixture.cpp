// block_average and check_equilibration on the shared fixture (tests/fixtures/): the C++ must
// give the numbers the bench's Python (scripts/hardrod_bench/stats.py) wrote there, to 1e-12,
// so the harnesses' statistics are the program's. tests/scripts/check_statistics.py checks
// the Python side against the same file. The series themselves are in block_average_series.txt
// (regenerated, with the expected values, by check_statistics.py --write).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "kernels/block_average.hpp"

namespace hardrod {
namespace {

const std::string kFixtures = std::string(HARDROD_SOURCE_DIR) + "/tests/fixtures/";

// The words of a file, lines starting with '#' left out.
std::vector<std::string> words(const std::string &path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot read " << path;
  std::vector<std::string> out;
  std::string line, word;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    while (ls >> word) out.push_back(word);
  }
  return out;
}

// strtod: "inf" and "nan" too, which operator>> does not read.
double number(const std::string &word) { return std::strtod(word.c_str(), nullptr); }

std::map<std::string, std::vector<double>> read_series() {
  const std::vector<std::string> w = words(kFixtures + "block_average_series.txt");
  std::map<std::string, std::vector<double>> series;
  for (std::size_t i = 0; i + 1 < w.size();) {
    const std::size_t n = std::stoul(w[i + 1]);
    std::vector<double> &values = series[w[i]];
    for (std::size_t k = 0; k < n; ++k) values.push_back(number(w.at(i + 2 + k)));
    i += 2 + n;
  }
  return series;
}

void expect_close(double got, double want, const std::string &what) {
  if (std::isnan(want)) {
    EXPECT_TRUE(std::isnan(got)) << what;
  } else if (std::isinf(want)) {
    EXPECT_EQ(got, want) << what;
  } else {
    EXPECT_LE(std::fabs(got - want), 1e-12 * std::max(1.0, std::fabs(want)))
        << what << ": C++ " << got << ", Python " << want;
  }
}

TEST(BlockAverageFixture, AgreesWithThePythonOfTheBench) {
  const std::map<std::string, std::vector<double>> series = read_series();
  ASSERT_GE(series.size(), 5u);
  const std::vector<std::string> w = words(kFixtures + "block_average_expected.txt");
  constexpr std::size_t kColumns = 11;  // name and ten numbers
  ASSERT_EQ(w.size() % kColumns, 0u);
  ASSERT_EQ(w.size() / kColumns, series.size());
  for (std::size_t row = 0; row < w.size(); row += kColumns) {
    const std::string &name = w[row];
    ASSERT_TRUE(series.count(name)) << name;
    const std::vector<double> &values = series.at(name);
    const Estimate est = block_average(values);
    const EquilibrationCheck eq = check_equilibration(values);
    expect_close(est.mean, number(w[row + 1]), name + " mean");
    expect_close(est.error, number(w[row + 2]), name + " error");
    EXPECT_EQ(est.samples, std::stoll(w[row + 3])) << name;
    EXPECT_EQ(est.block_size, std::stoll(w[row + 4])) << name;
    EXPECT_EQ(est.converged, w[row + 5] == "1") << name;
    expect_close(eq.first_mean, number(w[row + 6]), name + " first_mean");
    expect_close(eq.first_error, number(w[row + 7]), name + " first_error");
    expect_close(eq.last_mean, number(w[row + 8]), name + " last_mean");
    expect_close(eq.last_error, number(w[row + 9]), name + " last_error");
    EXPECT_EQ(eq.equilibrated, w[row + 10] == "1") << name;
  }
}

}  // namespace
}  // namespace hardrod
