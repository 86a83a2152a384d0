#include "io/output_dir.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;

namespace ehpt::io {
namespace {

TEST(OutputDir, WritesUnderPartialAndRenamesOnCommit) {
  const fs::path root = fs::temp_directory_path() / "ehpt_outdir_test";
  fs::remove_all(root);
  const std::string final_dir = (root / "run").string();
  // an older complete run is replaced only at commit
  fs::create_directories(final_dir);
  std::ofstream(final_dir + "/summary.json") << "{}";
  std::ofstream(final_dir + "/old.txt") << "old";
  OutputDir dir;
  std::string error;
  ASSERT_TRUE(dir.open(final_dir, error)) << error;
  ASSERT_TRUE(write_file_atomically(dir.file("summary.json"), "{}\n", error)) << error;
  EXPECT_TRUE(fs::exists(final_dir + ".partial/summary.json"));
  EXPECT_TRUE(fs::exists(final_dir + "/old.txt"));
  ASSERT_TRUE(dir.commit(error)) << error;
  EXPECT_TRUE(fs::exists(final_dir + "/summary.json"));
  EXPECT_FALSE(fs::exists(final_dir + "/old.txt"));
  EXPECT_FALSE(fs::exists(final_dir + ".partial"));
  EXPECT_FALSE(fs::exists(final_dir + ".replaced"));
}

TEST(OutputDir, RefusesToReplaceAFolderThatIsNotAnEarlierRun) {
  const fs::path root = fs::temp_directory_path() / "ehpt_outdir_refuse";
  fs::remove_all(root);
  fs::create_directories(root / "notes");
  std::ofstream(root / "notes" / "notes.txt") << "mine";
  OutputDir dir;
  std::string error;
  EXPECT_FALSE(dir.open((root / "notes").string(), error));
  EXPECT_NE(error.find("is not an ehpt output folder"), std::string::npos) << error;
  EXPECT_TRUE(fs::exists(root / "notes" / "notes.txt"));
  EXPECT_FALSE(fs::exists(root / "notes.partial"));
  fs::create_directories(root / "empty");
  EXPECT_TRUE(dir.open((root / "empty").string(), error)) << error;
}

TEST(JsonObject, OrderedKeysExactNumbersNullForNan) {
  JsonObject inner;
  inner.number("a_J", 1.5);
  JsonObject j;
  j.text("scenario", "ev \"x\"");
  j.number("step_s", 0.001);
  j.number("bad", std::nan(""));
  j.integer("steps", 3);
  j.boolean("ok", true);
  j.object("audit", inner);
  EXPECT_EQ(j.str(),
            "{\n  \"scenario\": \"ev \\\"x\\\"\",\n  \"step_s\": 0.001,\n  \"bad\": null,\n  \"steps\": 3,\n"
            "  \"ok\": true,\n  \"audit\": {\n    \"a_J\": 1.5\n  }\n}");
}

}  // namespace
}  // namespace ehpt::io
