// SPDX-License-Identifier: BSD-3-Clause
// HandoffBuffer: the loop's text reaches the file in order, from another thread, and a writer
// that falls behind costs dropped text (counted), never a wait or an allocation.
#include "io/handoff_buffer.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>

namespace ehpt::io {
namespace {

TEST(HandoffBuffer, AFullBufferIsHandedOverAndEverythingArrivesInOrder) {
  HandoffBuffer b(16);
  std::string file;
  const auto write = [&](std::string_view t) { file += t; };
  EXPECT_TRUE(b.append("0123456789"));
  EXPECT_FALSE(b.wants_writer());  // below the threshold
  EXPECT_TRUE(b.append("abcdefgh"));
  EXPECT_TRUE(b.wants_writer());  // 18 bytes: handed over
  EXPECT_TRUE(b.append("XY"));     // into the other buffer
  b.take_handed(write);
  EXPECT_EQ(file, "0123456789abcdefgh");
  EXPECT_FALSE(b.wants_writer());
  b.take_all(write);
  EXPECT_EQ(file, "0123456789abcdefghXY");
  EXPECT_EQ(b.dropped_bytes(), 0);
}

TEST(HandoffBuffer, WithoutAWriterItDropsAndCountsInsteadOfGrowing) {
  HandoffBuffer b(8);  // two buffers of 16 bytes reserved
  std::size_t taken = 0, dropped = 0;
  for (int i = 0; i < 10; ++i) {
    if (b.append("abcde")) {
      taken += 5;
    } else {
      dropped += 5;
    }
  }
  EXPECT_GT(dropped, 0u);  // 0 if the buffers had grown
  EXPECT_LT(taken, 50u);
  EXPECT_EQ(b.dropped_bytes(), static_cast<std::int64_t>(dropped));
  std::string file;
  b.take_all([&](std::string_view t) { file += t; });
  EXPECT_EQ(file.size(), taken);
  std::string want;
  for (std::size_t k = 0; k < taken / 5; ++k) want += "abcde";
  EXPECT_EQ(file, want);
}

TEST(HandoffBuffer, AWriterThreadGetsEveryLineInOrder) {
  HandoffBuffer b(1024);
  std::string file;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    while (!done.load()) b.take_handed([&](std::string_view t) { file += t; });
  });
  std::string produced;
  std::int64_t lines = 0;
  for (int i = 0; i < 50000; ++i) {
    const std::string line = std::to_string(i) + "\n";
    while (!b.append(line)) {
    }  // the test waits for the writer; the loop would count and go on
    produced += line;
    ++lines;
  }
  done = true;
  writer.join();
  b.take_all([&](std::string_view t) { file += t; });
  EXPECT_EQ(lines, 50000);
  EXPECT_TRUE(file == produced);
}

}  // namespace
}  // namespace ehpt::io
