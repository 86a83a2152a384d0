// SPDX-License-Identifier: BSD-3-Clause
// io/zip: the archives ehpt fmu writes, read back; what a reader must refuse.
#include <gtest/gtest.h>

#include "io/zip.hpp"

namespace ehpt::io {
namespace {

TEST(Zip, Crc32IsZipsCheckValue) {
  EXPECT_EQ(crc32("123456789"), 0xCBF43926u);  // the CRC-32/ISO-HDLC check value
  EXPECT_EQ(crc32(""), 0u);
}

TEST(Zip, WhatIsStoredIsReadBackByteForByteAndTheArchiveIsAFunctionOfItsContent) {
  std::string binary(300, '\0');
  for (std::size_t i = 0; i < binary.size(); ++i) binary[i] = static_cast<char>(i * 7);
  const std::vector<ZipEntry> in{{"modelDescription.xml", "<x/>\n"}, {"binaries/x86_64-linux/m.so", binary},
                                 {"resources/empty.txt", ""}};
  std::string a, b, error;
  ASSERT_TRUE(zip_store(in, a, error)) << error;
  ASSERT_TRUE(zip_store(in, b, error)) << error;
  EXPECT_EQ(a, b);  // no time stamps: the same FMU is the same bytes
  std::vector<ZipEntry> out;
  ASSERT_TRUE(zip_read(a, out, error)) << error;
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(out[i].name, in[i].name);
    EXPECT_EQ(out[i].data, in[i].data);
  }
}

TEST(Zip, NamesThatLeaveTheFolderAndDamagedArchivesAreRefused) {
  std::string a, error;
  for (const char* bad : {"/etc/passwd", "../x", "a/../../x", "a//b", "a\\b", "", "./a"}) {
    EXPECT_FALSE(zip_store({{bad, "x"}}, a, error)) << bad;
    EXPECT_NE(error.find("is not a relative path"), std::string::npos) << error;
  }
  EXPECT_FALSE(zip_store({{"a", "1"}, {"a", "2"}}, a, error));
  EXPECT_NE(error.find("'a' twice"), std::string::npos) << error;

  ASSERT_TRUE(zip_store({{"a.txt", "hello"}}, a, error)) << error;
  std::vector<ZipEntry> out;
  std::string damaged = a;
  damaged[30 + 5] ^= 0x01;  // a bit of the data: the CRC no longer matches
  EXPECT_FALSE(zip_read(damaged, out, error));
  EXPECT_NE(error.find("CRC does not match"), std::string::npos) << error;
  EXPECT_FALSE(zip_read(a.substr(0, a.size() - 3), out, error));  // cut short
  EXPECT_FALSE(zip_read("not a zip at all, just text", out, error));
  // a name that would leave the folder, written by someone else: refused on reading
  std::string evil = a;
  const std::size_t name_at = evil.rfind("a.txt");  // the central directory's copy
  evil.replace(name_at, 5, "../ab");
  EXPECT_FALSE(zip_read(evil, out, error));
  EXPECT_NE(error.find("would leave the folder"), std::string::npos) << error;
}

}  // namespace
}  // namespace ehpt::io
