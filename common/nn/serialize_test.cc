// Save / load round trips bit-exact; every kind of bad file gives a clear error.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "common/nn/mlp.h"
#include "common/nn/serialize.h"

namespace coins::nn {
namespace {

MlpOptions Small() { return {{4, 16, 8, 2}, Activation::kRelu, Activation::kIdentity}; }

bool Contains(const Status& s, const std::string& text) { return s.message().find(text) != std::string::npos; }

TEST(Serialize, Crc32KnownValue) {
  const char* text = "123456789";
  EXPECT_EQ(Crc32({reinterpret_cast<const uint8_t*>(text), 9}), 0xCBF43926u);
}

TEST(Serialize, BlobRoundTripIsBitExact) {
  Mlp a(Small(), 1), b(Small(), 2);
  ASSERT_NE(std::memcmp(a.params().values.data(), b.params().values.data(), 4), 0);
  std::vector<uint8_t> blob = ToBlob(a.params());
  ASSERT_TRUE(FromBlob(blob, &b.params()).ok());
  ASSERT_EQ(std::memcmp(a.params().values.data(), b.params().values.data(), size_t(a.params().size()) * 4), 0);
  Eigen::MatrixXf x = Eigen::MatrixXf::Random(4, 3);
  Eigen::MatrixXf ya = a.Forward(x);
  EXPECT_EQ(ya, b.Forward(x));
  EXPECT_EQ(ToBlob(b.params()), blob);
}

TEST(Serialize, SetOfNetworksInOneBlob) {
  Mlp a(Small(), 1), b({{3, 5, 1}, Activation::kTanh, Activation::kIdentity}, 2);
  const ParamSet* out[2] = {&a.params(), &b.params()};
  std::vector<uint8_t> blob = ToBlob(std::span<const ParamSet* const>(out, 2));
  Mlp a2(Small(), 3), b2({{3, 5, 1}, Activation::kTanh, Activation::kIdentity}, 4);
  ParamSet* in[2] = {&a2.params(), &b2.params()};
  ASSERT_TRUE(FromBlob(blob, std::span<ParamSet* const>(in, 2)).ok());
  EXPECT_EQ(a2.params().values, a.params().values);
  EXPECT_EQ(b2.params().values, b.params().values);
  // the order matters: swapped destinations are a shape mismatch
  ParamSet* swapped[2] = {&b2.params(), &a2.params()};
  Status s = FromBlob(blob, std::span<ParamSet* const>(swapped, 2));
  EXPECT_TRUE(Contains(s, "shape mismatch")) << s.message();
  // a single network does not load from a two-network blob
  EXPECT_FALSE(FromBlob(blob, &a2.params()).ok());
}

TEST(Serialize, FileRoundTripAndBadFiles) {
  const std::string dir = ::testing::TempDir();
  const std::string path = dir + "/coins_nn_weights.bin";
  Mlp a(Small(), 1), b(Small(), 2);
  ASSERT_TRUE(SaveWeights(path, a.params()).ok());
  ASSERT_TRUE(LoadWeights(path, &b.params()).ok());
  EXPECT_EQ(a.params().values, b.params().values);

  std::vector<uint8_t> good = ToBlob(a.params());
  auto write = [&](const std::vector<uint8_t>& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  };
  Mlp c(Small(), 3);
  const Eigen::VectorXf before = c.params().values;

  // bad magic
  std::vector<uint8_t> bytes = good;
  bytes[0] = 'X';
  write(bytes);
  Status s = LoadWeights(path, &c.params());
  EXPECT_TRUE(Contains(s, path) && Contains(s, "bad magic")) << s.message();
  // unsupported version
  bytes = good;
  bytes[4] = 9;
  write(bytes);
  s = LoadWeights(path, &c.params());
  EXPECT_TRUE(Contains(s, "version 9")) << s.message();
  // truncated
  bytes = good;
  bytes.resize(bytes.size() - 17);
  write(bytes);
  s = LoadWeights(path, &c.params());
  EXPECT_TRUE(Contains(s, "truncated")) << s.message();
  // one flipped bit in the values
  bytes = good;
  bytes[bytes.size() - 40] ^= 0x10;
  write(bytes);
  s = LoadWeights(path, &c.params());
  EXPECT_TRUE(Contains(s, "checksum mismatch")) << s.message();
  // another architecture
  write(good);
  Mlp other({{4, 16, 3, 2}, Activation::kRelu, Activation::kIdentity}, 1);
  s = LoadWeights(path, &other.params());
  EXPECT_TRUE(Contains(s, "shape mismatch") && Contains(s, "layer1.w")) << s.message();
  // missing file
  s = LoadWeights(dir + "/does_not_exist.bin", &c.params());
  EXPECT_TRUE(Contains(s, "cannot open")) << s.message();
  // failed loads leave the destination untouched
  EXPECT_EQ(c.params().values, before);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace coins::nn
