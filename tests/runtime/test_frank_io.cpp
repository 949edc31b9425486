// The Frank data's JSON and files (runtime/frank_io.hpp): an accumulator survives a JSON and
// a file round trip exactly, malformed input and missing files are rejected, and a reloaded
// accumulator fits to the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "kernels/fourier_order_tensor.hpp"
#include "runtime/frank_io.hpp"
#include "tests/synthetic_nematic.hpp"

namespace hardrod {
namespace {

TEST(FrankIo, JsonRoundTripIsExactAndMalformedInputIsRejected) {
  const Box box{{10.0, 10.0, 10.0}};
  Particles p;
  p.resize(1);
  p.set_axis(0, {std::sin(0.3), 0.0, std::cos(0.3)});
  const FourierOrderTensor qk = fourier_order_tensor(p, 1, box, 2);
  FrankAccumulator a(box, 1, 2);
  a.add_sample(qk, {0.1, 0.2, 1.0}, 0.7);
  a.add_sample(qk, {0.0, 0.3, 1.0}, 0.75);
  const nlohmann::json j = to_json(a);
  const FrankAccumulator back = frank_accumulator_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(to_json(back), j);
  EXPECT_EQ(back.samples(), 2);
  EXPECT_THROW(frank_accumulator_from_json(nlohmann::json{{"format", "something else"}}),
               std::invalid_argument);
  nlohmann::json broken = j;
  broken["blocks"][0]["bins"][0].erase(0);
  EXPECT_THROW(frank_accumulator_from_json(broken), std::invalid_argument);
  EXPECT_THROW(load_frank_accumulator("/nonexistent/frank.json"), std::runtime_error);
}

// A saved and reloaded accumulator gives the same fit, bit for bit (a small system: this is
// about the file, not the physics).
TEST(FrankIo, AccumulatorSurvivesAFileRoundTrip) {
  using namespace synthetic;
  SyntheticNematic s;
  s.side = 28.5256;  // the everyday scene's box
  s.bodies = 2304;
  s.kmax = 3;
  FrankAccumulator acc(Box{{s.side, s.side, s.side}}, static_cast<long long>(s.bodies), s.kmax,
                       block_config());
  accumulate(s, 30, 77, acc);
  const std::string path = ::testing::TempDir() + "frank_accumulator_roundtrip.json";
  save_frank_accumulator(acc, path);
  const FrankAccumulator back = load_frank_accumulator(path);
  std::remove(path.c_str());
  EXPECT_EQ(to_json(back), to_json(acc));
  FrankFitOptions o = fit_options(true);
  o.min_bin_count = 2;
  const nlohmann::json a = to_json(fit_frank({acc}, o)), b = to_json(fit_frank({back}, o));
  EXPECT_EQ(a, b);
  EXPECT_TRUE(a["planar"]["K1"]["value"].is_number()) << a["planar"].dump();
}

}  // namespace
}  // namespace hardrod
