// SPDX-License-Identifier: BSD-3-Clause
#include "io/output_dir.hpp"
#include "io/json_value.hpp"

#include <gtest/gtest.h>

#include "test_plants.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace ehpt::io {
namespace {

// A fresh scratch folder per test.
fs::path scratch(const std::string& name) {
  const fs::path root = ehpt::test::scratch_root() / ("ehpt_outdir_" + name);
  fs::remove_all(root);
  fs::create_directories(root);
  return root;
}

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A complete run into dir with the given files.
void run_into(const std::string& dir, const std::vector<std::pair<std::string, std::string>>& files) {
  OutputDir out;
  std::string error;
  ASSERT_TRUE(out.open(dir, error)) << error;
  for (const auto& [name, text] : files) ASSERT_TRUE(write_file_atomically(out.file(name), text, error)) << error;
  ASSERT_TRUE(out.commit(error)) << error;
}

TEST(OutputDir, WritesIntoAPrivateFolderAndCommitsWithAManifest) {
  const fs::path root = scratch("commit");
  const std::string dir = (root / "run").string();
  OutputDir out;
  std::string error;
  ASSERT_TRUE(out.open(dir, error)) << error;
  EXPECT_EQ(out.partial_dir(), dir + ".partial-" + std::to_string(::getpid()));
  EXPECT_TRUE(fs::exists(dir + ".ehpt-lock"));
  ASSERT_TRUE(write_file_atomically(out.file("summary.json"), "{}\n", error)) << error;
  EXPECT_FALSE(fs::exists(dir));
  ASSERT_TRUE(out.commit(error)) << error;
  EXPECT_EQ(read(dir + "/summary.json"), "{}\n");
  EXPECT_EQ(read(dir + "/ehpt-manifest.txt"), std::string(kManifestMagic) + "\nsummary.json\n");
  EXPECT_FALSE(fs::exists(out.partial_dir()));
  EXPECT_FALSE(fs::exists(dir + ".ehpt-lock"));  // ours, removed
  EXPECT_EQ(std::distance(fs::directory_iterator(root), fs::directory_iterator()), 1);  // only run/
}

// A folder name of 255 bytes is a valid --out: its lock and temporary folder beside it are
// named within the 255-byte limit too (they were DIR + ".ehpt-lock.tmp-PID": refused from 246),
// for a new run and for one that replaces it.
TEST(OutputDir, AFolderNameOfTheFullLengthIsAnOutputFolder) {
  const fs::path root = scratch("long");
  for (const std::size_t length : {200u, 240u, 246u, 255u}) {
    const std::string dir = (root / std::string(length, 'r')).string();
    run_into(dir, {{"summary.json", "first"}});
    run_into(dir, {{"summary.json", "second"}});  // replaces the earlier run
    EXPECT_EQ(read(dir + "/summary.json"), "second") << length;
    // nothing left beside it: the lock, the temporary and the replaced folders were ours
    EXPECT_EQ(std::distance(fs::directory_iterator(root), fs::directory_iterator()), 1) << length;
    fs::remove_all(dir);
  }
  // "DIR/" is DIR: the same lock (ehpt plot out/run/ against ehpt run --out out/run)
  {
    const std::string d = (root / "slash").string();
    OutputDir run;
    std::string e;
    ASSERT_TRUE(run.open(d, e)) << e;
    DirLock plot;
    EXPECT_FALSE(plot.acquire(d + "/", e));
    EXPECT_NE(e.find("another ehpt run is writing this folder"), std::string::npos) << e;
    EXPECT_FALSE(fs::exists(d + "/.ehpt-lock"));
  }
  // a second run with the same long name finds the first one's lock
  const std::string dir = (root / std::string(255, 'q')).string();
  OutputDir first, second;
  std::string error;
  ASSERT_TRUE(first.open(dir, error)) << error;
  EXPECT_FALSE(second.open(dir, error));
  EXPECT_NE(error.find("another ehpt run is writing this folder"), std::string::npos) << error;
}

TEST(OutputDir, ReplacesAnEarlierRunDeletingOnlyTheFilesItsManifestLists) {
  const fs::path root = scratch("replace");
  const std::string dir = (root / "run").string();
  run_into(dir, {{"summary.json", "old"}, {"timeseries.csv", "old"}, {"speed.png", "old"}});
  run_into(dir, {{"summary.json", "new"}});
  EXPECT_EQ(read(dir + "/summary.json"), "new");
  EXPECT_FALSE(fs::exists(dir + "/timeseries.csv"));
  EXPECT_FALSE(fs::exists(dir + "/speed.png"));
  EXPECT_EQ(std::distance(fs::directory_iterator(root), fs::directory_iterator()), 1);
}

TEST(OutputDir, NeverReplacesAFolderOfSomeoneElsesFiles) {
  const fs::path root = scratch("foreign");
  std::string error;
  // the review's case: a project folder that happens to hold a summary.json
  const fs::path project = root / "project";
  write(project / "src/main.c", "int main() {}");
  write(project / "README.txt", "mine");
  write(project / "summary.json", "{}");
  OutputDir a;
  EXPECT_FALSE(a.open(project.string(), error));
  EXPECT_NE(error.find("is not an earlier ehpt run"), std::string::npos) << error;
  // an earlier run to which the user added a file is not replaced either
  const std::string run = (root / "run").string();
  run_into(run, {{"summary.json", "old"}});
  write(fs::path(run) / "notes.txt", "my notes");
  OutputDir b;
  EXPECT_FALSE(b.open(run, error));
  EXPECT_NE(error.find("it holds files ehpt did not write: notes.txt"), std::string::npos) << error;
  // a manifest that is not ehpt's does not count
  const fs::path fake = root / "fake";
  write(fake / "ehpt-manifest.txt", "summary.json\n");
  write(fake / "summary.json", "{}");
  OutputDir c;
  EXPECT_FALSE(c.open(fake.string(), error));
  // a symbolic link is refused, not followed
  fs::create_directory_symlink(project, root / "link");
  OutputDir d;
  EXPECT_FALSE(d.open((root / "link").string(), error));
  EXPECT_NE(error.find("symbolic link"), std::string::npos) << error;
  // everything is as it was, and no folder of ours was left
  EXPECT_EQ(read(project / "src/main.c"), "int main() {}");
  EXPECT_EQ(read(project / "README.txt"), "mine");
  EXPECT_EQ(read(fs::path(run) / "notes.txt"), "my notes");
  EXPECT_EQ(read(fake / "summary.json"), "{}");
  for (const auto& e : fs::directory_iterator(root)) {
    EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
    EXPECT_EQ(e.path().filename().string().find(".ehpt-lock"), std::string::npos) << e.path();
  }
  // an empty folder is used
  fs::create_directories(root / "empty");
  run_into((root / "empty").string(), {{"summary.json", "x"}});
  EXPECT_EQ(read(root / "empty/summary.json"), "x");
}

TEST(OutputDir, NeverTouchesTheUsersPartialOrReplacedPaths) {
  const fs::path root = scratch("user_paths");
  const std::string dir = (root / "run").string();
  // the old fixed names, and the very names this process would pick first
  const std::string pid = std::to_string(::getpid());
  write(dir + ".partial/keep.txt", "a folder of mine");
  write(dir + ".replaced", "a file of mine");
  write(dir + ".partial-" + pid + "/keep.txt", "mine, with your pid");
  write(dir + ".replaced-" + pid, "mine too, with your pid");
  run_into(dir, {{"summary.json", "1"}});
  run_into(dir, {{"summary.json", "2"}});  // replaces the first run
  EXPECT_EQ(read(dir + ".partial/keep.txt"), "a folder of mine");
  EXPECT_EQ(read(dir + ".replaced"), "a file of mine");
  EXPECT_EQ(read(dir + ".partial-" + pid + "/keep.txt"), "mine, with your pid");
  EXPECT_EQ(read(dir + ".replaced-" + pid), "mine too, with your pid");
  EXPECT_EQ(read(dir + "/summary.json"), "2");
  // a lock file of that name that is not ehpt's is used, and left in place
  write(dir + ".ehpt-lock", "");
  run_into(dir, {{"summary.json", "3"}});
  EXPECT_TRUE(fs::exists(dir + ".ehpt-lock"));
  EXPECT_EQ(read(dir + "/summary.json"), "3");
}

TEST(OutputDir, ASecondRunOnTheSameFolderStopsAtOnce) {
  const fs::path root = scratch("lock");
  const std::string dir = (root / "run").string();
  std::string error;
  OutputDir first;
  ASSERT_TRUE(first.open(dir, error)) << error;
  ASSERT_TRUE(write_file_atomically(first.file("summary.json"), "first", error));
  OutputDir second;
  EXPECT_FALSE(second.open(dir, error));
  EXPECT_NE(error.find("another ehpt run is writing this folder"), std::string::npos) << error;
  ASSERT_TRUE(first.commit(error)) << error;
  EXPECT_EQ(read(dir + "/summary.json"), "first");
  // once the first has committed, the folder is an earlier run and may be replaced
  OutputDir third;
  EXPECT_TRUE(third.open(dir, error)) << "[" << error << "]";
}

TEST(OutputDir, AnExceptionRemovesTheFolderItMadeAReturnKeepsIt) {
  const fs::path root = scratch("unwind");
  std::string kept;
  {
    OutputDir out;
    std::string error;
    ASSERT_TRUE(out.open((root / "a").string(), error));
    ASSERT_TRUE(write_file_atomically(out.file("timeseries.csv"), "t\n", error));
    kept = out.partial_dir();
  }
  EXPECT_TRUE(fs::exists(kept + "/timeseries.csv"));  // like a crash: the data so far is kept
  std::string removed;
  try {
    OutputDir out;
    std::string error;
    ASSERT_TRUE(out.open((root / "b").string(), error));
    removed = out.partial_dir();
    throw std::bad_alloc();
  } catch (const std::bad_alloc&) {
  }
  EXPECT_FALSE(removed.empty());
  EXPECT_FALSE(fs::exists(removed));
  EXPECT_FALSE(fs::exists(root / "b.ehpt-lock"));
}

TEST(OutputDir, AnInterruptedRunDoesNotReplaceAnEarlierOne) {
  const fs::path root = scratch("interrupted");
  const std::string dir = (root / "run").string();
  run_into(dir, {{"summary.json", "complete"}});
  OutputDir out;
  std::string error;
  ASSERT_TRUE(out.open(dir, error)) << error;
  ASSERT_TRUE(write_file_atomically(out.file("summary.json"), "interrupted", error));
  ASSERT_TRUE(out.commit(error, /*replace_earlier=*/false)) << error;
  EXPECT_EQ(read(dir + "/summary.json"), "complete");
  EXPECT_EQ(out.results_dir(), out.partial_dir());
  EXPECT_EQ(read(out.partial_dir() + "/summary.json"), "interrupted");
  ASSERT_EQ(out.warnings().size(), 1u);
  EXPECT_NE(out.warnings()[0].find("was kept; this run's outputs are in"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir + ".ehpt-lock"));
  // into an empty place it is committed as usual
  OutputDir fresh_out;
  ASSERT_TRUE(fresh_out.open((root / "new").string(), error));
  ASSERT_TRUE(fresh_out.commit(error, false)) << error;
  EXPECT_EQ(fresh_out.results_dir(), (root / "new").string());
}

TEST(OutputDir, ManifestGrowsWithLaterFigures) {
  const fs::path root = scratch("manifest");
  const std::string dir = (root / "run").string();
  run_into(dir, {{"summary.json", "x"}});
  std::string error;
  ASSERT_TRUE(add_to_manifest(dir, {"speed.png"}, error)) << error;
  write(fs::path(dir) / "speed.png", "png");
  std::vector<std::string> files;
  std::string why;
  ASSERT_TRUE(is_earlier_run(dir, files, why)) << why;
  EXPECT_EQ(files, (std::vector<std::string>{"speed.png", "summary.json"}));
  EXPECT_FALSE(add_to_manifest(dir, {"../escape"}, error));
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

// A path in Latin-1 (or any bytes): the summary stays valid JSON that our strict reader
// takes; well-formed UTF-8 passes through unchanged, every other byte is U+FFFD.
TEST(JsonObject, BytesThatAreNotUtf8BecomeReplacementCharacters) {
  EXPECT_EQ(json_escape("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x9a\x97"), "\"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x9a\x97\"");
  EXPECT_EQ(json_escape("caf\xe9/x"), "\"caf\\ufffd/x\"");               // Latin-1 e-acute
  EXPECT_EQ(json_escape("\xc0\xaf"), "\"\\ufffd\\ufffd\"");            // overlong '/'
  EXPECT_EQ(json_escape("\xed\xa0\x80"), "\"\\ufffd\\ufffd\\ufffd\""); // a surrogate
  EXPECT_EQ(json_escape("\xf4\x90\x80\x80"), "\"\\ufffd\\ufffd\\ufffd\\ufffd\"");  // above U+10FFFF
  EXPECT_EQ(json_escape("\xe2\x82"), "\"\\ufffd\\ufffd\"");            // cut short at the end
  JsonObject j;
  j.text("path", "/data/caf\xe9\xff.toml");
  JsonValue v;
  std::string error;
  ASSERT_TRUE(parse_json(j.str(), v, error)) << error;
  EXPECT_EQ(v.find("path")->text, "/data/caf\xef\xbf\xbd\xef\xbf\xbd.toml");
}

}  // namespace
}  // namespace ehpt::io
