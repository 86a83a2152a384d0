// SPDX-License-Identifier: BSD-3-Clause
#include "io/csv_table.hpp"

#include <gtest/gtest.h>

#include "test_plants.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "io/number_format.hpp"

namespace ehpt::io {
namespace {

std::string write_temp(const std::string& name, const std::string& content) {
  const auto dir = ehpt::test::scratch_root() / "ehpt_io_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << content;
  return path;
}

TEST(CsvTable, ReadsHeaderColumnsAndLines) {
  const std::string path = write_temp("ok.csv", "time_s,speed_kmh\n# comment\n0,0\n\n5.39, 20\n");
  CsvTable t;
  std::vector<std::string> errors;
  ASSERT_TRUE(read_csv_table(path, t, errors));
  EXPECT_EQ(t.header, (std::vector<std::string>{"time_s", "speed_kmh"}));
  EXPECT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.lines, (std::vector<int>{3, 5}));
  EXPECT_DOUBLE_EQ(t.columns[1][1], 20.0);
  EXPECT_EQ(t.column_index("speed_kmh"), 1);
  EXPECT_EQ(t.column_index("nope"), -1);
}

TEST(CsvTable, ReportsEveryBadFieldWithFileLineAndColumn) {
  const std::string path = write_temp("bad.csv", "time_s,speed_kmh\n0,0\n1,\"12,5\"\n2,abc\n3\n4,1,2\n5,\"7\n");
  CsvTable t;
  std::vector<std::string> errors;
  EXPECT_FALSE(read_csv_table(path, t, errors));
  ASSERT_EQ(errors.size(), 5u);
  // a quoted field is one field: "12,5" (a decimal comma) is not a number, and is named so
  EXPECT_EQ(errors[0], path + ":3: column speed_kmh: \"12,5\" is not a number");
  EXPECT_EQ(errors[1], path + ":4: column speed_kmh: \"abc\" is not a number");
  EXPECT_EQ(errors[2], path + ":5: 1 fields, expected 2 as in the header");
  EXPECT_EQ(errors[3], path + ":6: 3 fields, expected 2 as in the header");
  EXPECT_EQ(errors[4], path + ":7: a quote is opened and not closed");
}

TEST(CsvTable, QuotedFieldsAndAByteOrderMarkAreRead) {
  // as a spreadsheet exports it: BOM, quoted header and numbers, CRLF line ends
  const std::string path =
      write_temp("excel.csv", "\xEF\xBB\xBF\"time_s\",\"speed_kmh\"\r\n\"0\",\"0\"\r\n\"5.39\", \"20\" \r\n");
  CsvTable t;
  std::vector<std::string> errors;
  ASSERT_TRUE(read_csv_table(path, t, errors)) << errors[0];
  EXPECT_EQ(t.header, (std::vector<std::string>{"time_s", "speed_kmh"}));
  EXPECT_EQ(t.column_index("time_s"), 0);  // not "\xEF\xBB\xBFtime_s"
  ASSERT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.columns[0][1], 5.39);
  EXPECT_EQ(t.columns[1][1], 20.0);
  EXPECT_EQ(t.text[1][1], "20");
}

TEST(CsvTable, ListsTheFirstTwentyProblemsOfAFileAndCountsTheRest) {
  std::string garbage = "a,b\n";
  for (int i = 0; i < 1000; ++i) garbage += "x,y\n";
  CsvTable t;
  std::vector<std::string> errors;
  EXPECT_FALSE(read_csv_table(write_temp("garbage.csv", garbage), t, errors));
  ASSERT_EQ(errors.size(), 21u);
  EXPECT_NE(errors.back().find("1980 more problems in this file"), std::string::npos) << errors.back();
}

TEST(CsvTable, EmptyAndMissingFiles) {
  CsvTable t;
  std::vector<std::string> errors;
  EXPECT_FALSE(read_csv_table(write_temp("empty.csv", ""), t, errors));
  EXPECT_FALSE(read_csv_table(write_temp("header.csv", "time_s,speed_kmh\n"), t, errors));
  EXPECT_FALSE(read_csv_table("/nonexistent/x.csv", t, errors));
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_NE(errors[0].find("empty file"), std::string::npos);
  EXPECT_NE(errors[1].find("no data rows"), std::string::npos);
  EXPECT_EQ(errors[2], "/nonexistent/x.csv: cannot read: no such file");
}

TEST(NumberFormat, ShortestRoundTripAndStrictParse) {
  for (double v : {0.1, 1.0 / 3.0, -2.5e-300, 123456789.123, 0.0}) {
    double back = 0.0;
    ASSERT_TRUE(parse_number(number_text(v), back));
    EXPECT_EQ(back, v);
  }
  EXPECT_EQ(number_text(0.1), "0.1");
  EXPECT_EQ(number_text(std::nan("")), "nan");
  double v = 0.0;
  EXPECT_FALSE(parse_number("12,5", v));
  EXPECT_FALSE(parse_number("", v));
  EXPECT_FALSE(parse_number("1.0x", v));
  EXPECT_TRUE(parse_number(" +4.5 ", v));
  EXPECT_EQ(v, 4.5);
}

}  // namespace
}  // namespace ehpt::io
