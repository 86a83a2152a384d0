// SPDX-License-Identifier: BSD-3-Clause
#include "io/sha256.hpp"

#include <gtest/gtest.h>

#include <string>

#include "io/text_file.hpp"

namespace ehpt::io {
namespace {

// FIPS 180-4 examples (NIST CSRC "SHA256.pdf", "SHA2 additional" vectors).
TEST(Sha256, NistShortMessages) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  // 448 bits: the padding's 0x80 fits in the block, the length does not (two blocks)
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  // 896 bits
  EXPECT_EQ(sha256_hex("abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmno"
                       "ijklmnopjklmnopqklmnopqrlmnopqrsmnopqrstnopqrstu"),
            "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
}

TEST(Sha256, OneMillionAInOddChunks) {
  const std::string chunk(997, 'a');  // prime: the chunks straddle block boundaries
  Sha256 s;
  std::size_t left = 1000000;
  while (left > 0) {
    const std::size_t n = left < chunk.size() ? left : chunk.size();
    s.update(std::string_view(chunk).substr(0, n));
    left -= n;
  }
  EXPECT_EQ(to_hex(s.finish()), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, EverySplitPointGivesTheSameDigest) {
  std::string message;
  for (int i = 0; i < 200; ++i) message += static_cast<char>((i * 37 + 11) & 0xff);  // all byte values mixed
  const std::string whole = sha256_hex(message);
  Sha256 s;  // reused: finish() must reset it
  for (std::size_t cut = 0; cut <= message.size(); ++cut) {
    s.update(std::string_view(message).substr(0, cut));
    s.update("");  // an empty update changes nothing
    s.update(std::string_view(message).substr(cut));
    ASSERT_EQ(to_hex(s.finish()), whole) << "split at " << cut;
  }
  // and three pieces at every pair of points around the 64-byte boundaries
  for (std::size_t a = 50; a < 80; ++a) {
    for (std::size_t b = a; b < 140; ++b) {
      s.update(std::string_view(message).substr(0, a));
      s.update(std::string_view(message).substr(a, b - a));
      s.update(std::string_view(message).substr(b));
      ASSERT_EQ(to_hex(s.finish()), whole) << "split at " << a << ", " << b;
    }
  }
}

TEST(Sha256, PaddingAtEveryLengthAroundABlock) {
  // 55 bytes: the length still fits; 56..63: it spills into a second block (sha256sum)
  EXPECT_EQ(sha256_hex(std::string(55, 'a')), "9f4390f8d30c2dd92ec9f095b65e2b9ae9b0a925a5258e241c9f1e910f734318");
  EXPECT_EQ(sha256_hex(std::string(56, 'a')), "b35439a4ac6f0948b6d6f9e3c6af0f5f590ce20f1bde7090ef7970686ec6738a");
  EXPECT_EQ(sha256_hex(std::string(64, 'a')), "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb");
}

TEST(Sha256, MatchesSha256sumOfACycleFile) {
  // `sha256sum data/cycles/cycle_nedc.csv`, as listed in data/SHA256SUMS; if the cycle file is
  // ever changed on purpose, update both.
  const std::string path = std::string(EHPT_TEST_DATA_DIR) + "/../../data/cycles/cycle_nedc.csv";
  std::string content, reason;
  ASSERT_TRUE(read_text_file(path, content, reason)) << path << ": " << reason;
  EXPECT_EQ(sha256_hex(content), "1b9e2981e28172f6c9da979f3722a4e5679d5bd604de00ba464ba6663c650a6b");
}

// NIST's long message: 2^33 bits, so a bit count kept in 32 bits would give another digest.
// About 4 s; run with --gtest_also_run_disabled_tests.
TEST(Sha256, DISABLED_GigabyteMessageNeedsA64BitLength) {
  std::string piece;
  for (int i = 0; i < 1024; ++i) piece += "abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmno";
  Sha256 s;
  for (int i = 0; i < 16384; ++i) s.update(piece);  // 16 777 216 x 64 bytes = 1 GiB
  EXPECT_EQ(to_hex(s.finish()), "50e72a0e26442fe2552dc3938ac58658228c0cbfb1d2ca872ae435266fcd055e");
}

}  // namespace
}  // namespace ehpt::io
