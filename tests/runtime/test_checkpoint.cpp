// Checkpoint files in-process (one rank): exact round trip, and the checks a reader makes.
// The end-to-end tests (resume, signals, hostile files) are tests/scripts/check_checkpoint.py.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "runtime/checkpoint.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

Particles random_bodies(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(n - 1 - i);  // stored in reverse: the file sorts by id
    p.set_position(i, {g(rng) * 10, g(rng) * 10, g(rng) * 10});
    Vec3 e{g(rng), g(rng), g(rng)};
    p.set_axis(i, e * (1.0 / norm(e)));
    p.set_velocity(i, {g(rng), g(rng), g(rng)});
    p.set_angular_velocity(i, {g(rng), g(rng), g(rng)});
  }
  return p;
}

Particles in_id_order(const Particles &p) {
  Particles q = p;
  std::vector<std::uint32_t> order(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) order[static_cast<std::size_t>(p.id[i])] = i;
  q.permute(order);
  return q;
}

struct CheckpointFiles : ::testing::Test {
  fs::path dir;
  Communicator comm;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("hardrod-ckpt-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
           "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  Checkpoint contents(const Particles &p) {
    Checkpoint c;
    c.step = 12345;
    c.n = static_cast<long long>(p.size());
    c.state_checksum = fmt::format("{:016x}", body_hash(in_id_order(p)));
    c.scene_toml = "[system]\nn = " + std::to_string(p.size()) + "\n";
    c.run_state = R"({"x": 0.1})";
    c.root_state = "{}";
    return c;
  }
};

TEST_F(CheckpointFiles, RoundTripIsBitExactInIdOrder) {
  const Particles p = random_bodies(300, 1);
  write_checkpoint(comm, dir, p, p.size(), contents(p));
  const Checkpoint c = read_checkpoint(dir / kCheckpointFile);
  EXPECT_EQ(c.step, 12345);
  EXPECT_EQ(c.n, 300);
  EXPECT_EQ(c.run_state, R"({"x": 0.1})");
  EXPECT_EQ(c.root_state, "{}");
  const Particles expected = in_id_order(p);
  ASSERT_EQ(c.bodies.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(c.bodies.id[i], static_cast<std::int64_t>(i));
    for (BodyField f : kStateFields)  // every state field, bit for bit
      EXPECT_EQ(std::memcmp(&(c.bodies.*f)[i], &(expected.*f)[i], sizeof(double)), 0) << i;
  }
  EXPECT_EQ(body_hash(c.bodies), body_hash(expected));
}

TEST_F(CheckpointFiles, KeepsThePreviousCheckpointAndLeavesNoTemporary) {
  const Particles p = random_bodies(50, 2);
  Checkpoint c = contents(p);
  write_checkpoint(comm, dir, p, p.size(), c);
  c.step = 99;
  write_checkpoint(comm, dir, p, p.size(), c);
  EXPECT_EQ(read_checkpoint(dir / kCheckpointFile).step, 99);
  EXPECT_EQ(read_checkpoint(dir / kPreviousCheckpointFile).step, 12345);
  EXPECT_FALSE(fs::exists(dir / (std::string(kCheckpointFile) + ".tmp")));
}

void expect_rejected(const fs::path &path, const std::string &words) {
  try {
    read_checkpoint(path);
    FAIL() << "accepted a bad checkpoint; expected: " << words;
  } catch (const CheckpointError &e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
}

TEST_F(CheckpointFiles, RejectsNonFiniteValuesAndNonUnitAxes) {
  Particles p = random_bodies(20, 3);
  p.vx[4] = std::nan("");
  write_checkpoint(comm, dir, p, p.size(), contents(p));
  expect_rejected(dir / kCheckpointFile, "not finite");

  p = random_bodies(20, 3);
  p.ex[7] *= 1.001;
  write_checkpoint(comm, dir, p, p.size(), contents(p));
  expect_rejected(dir / kCheckpointFile, "unit vectors");
}

TEST_F(CheckpointFiles, RefusesToWriteOneIdTwiceAndKeepsTheGoodOne) {
  Particles p = random_bodies(20, 3);
  write_checkpoint(comm, dir, p, p.size(), contents(p));
  p.id[0] = p.id[1];
  EXPECT_THROW(write_checkpoint(comm, dir, p, p.size(), contents(p)), CheckpointError);
  EXPECT_EQ(read_checkpoint(dir / kCheckpointFile).n, 20);
}

TEST_F(CheckpointFiles, RejectsEveryTruncationAndABitFlipAnywhere) {
  const Particles p = random_bodies(40, 4);
  write_checkpoint(comm, dir, p, p.size(), contents(p));
  std::ifstream in(dir / kCheckpointFile, std::ios::binary);
  const std::vector<char> good(std::istreambuf_iterator<char>(in), {});
  const fs::path bad = dir / "bad.h5";
  auto write = [&](const std::vector<char> &bytes) {
    std::ofstream out(bad, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  };
  for (std::size_t size : {std::size_t{0}, std::size_t{511}, good.size() / 3, good.size() - 1}) {
    write(std::vector<char>(good.begin(), good.begin() + static_cast<long>(size)));
    expect_rejected(bad, size < 512 ? "truncated" : "truncated or extended");
  }
  std::mt19937 rng(5);
  for (int k = 0; k < 50; ++k) {
    std::vector<char> flipped = good;
    const std::size_t at = 512 + rng() % (good.size() - 512);
    flipped[at] = static_cast<char>(flipped[at] ^ (1 << (rng() % 8)));
    write(flipped);
    expect_rejected(bad, "corrupted");
  }
  expect_rejected(dir / "absent.h5", "no such checkpoint file");
}

}  // namespace
}  // namespace hardrod
