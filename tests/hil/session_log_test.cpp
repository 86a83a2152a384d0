// SPDX-License-Identifier: BSD-3-Clause
// inputs.log read as a stream (hil/bus/session_log.hpp): the validating read's digest is the
// file's, the reader gives back every command exactly, and a log that changes between the
// check and the replay is an error, never a silently different replay.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "hil/bus/session_log.hpp"
#include "io/sha256.hpp"

namespace ehpt {
namespace {

namespace fs = std::filesystem;

std::string temp_log(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / "ehpt_session_log_test";
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

const char* kHead = "# ehpt inputs log 1\n# scenario /x/ev.toml\n# set a=1\n# set b=2\n# family ev\n# pacing lockstep\n";

TEST(InputsLog, TheCommandsComeBackExactlyAndTheDigestIsTheFiles) {
  std::string text = std::string(kHead) + "# fault kind=drop target=EvCommand at_s=1\n";
  std::vector<msgs::EvCommand> written;
  char line[256];
  for (int k = 0; k < 70000; ++k) {  // more than one 64 KiB block, lines across block ends
    msgs::EvCommand c;
    c.stamp = msgs::Stamp{0.01 * k, 10 * k, static_cast<std::uint32_t>(k)};
    c.driveTauRef_Nm = k % 7 == 0 ? -0.0 : 1.0 / (k + 3) - 0.17;
    written.push_back(c);
    text += std::string(line, static_cast<std::size_t>(hil::format_command(line, sizeof line, 10 * k, c))) + "\n";
  }
  const std::string path = temp_log("good.log", text);
  hil::InputsLog log;
  std::vector<std::string> problems;
  ASSERT_TRUE(hil::read_inputs_log(path, log, problems)) << problems.front();
  EXPECT_EQ(log.scenario_path, "/x/ev.toml");
  EXPECT_EQ(log.overrides, (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_EQ(log.faults, (std::vector<std::string>{"kind=drop target=EvCommand at_s=1"}));  // --fault: replayed too
  EXPECT_EQ(log.family, "ev");
  EXPECT_EQ(log.pacing, "lockstep");
  EXPECT_EQ(log.commands, 70000);
  EXPECT_EQ(log.file.bytes, text.size());
  EXPECT_EQ(log.file.sha256, io::sha256_hex(text));

  hil::InputsLogReader reader(path, log);
  std::int64_t step = -1;
  msgs::EvCommand c;
  std::size_t k = 0;
  for (; reader.next(step, c); ++k) {
    ASSERT_LT(k, written.size());
    EXPECT_EQ(step, static_cast<std::int64_t>(10 * k));
    EXPECT_EQ(std::memcmp(&c.driveTauRef_Nm, &written[k].driveTauRef_Nm, sizeof(double)), 0) << k;  // -0.0 too
    EXPECT_EQ(c.stamp.time_s, written[k].stamp.time_s);
    EXPECT_EQ(c.stamp.step, written[k].stamp.step);
    EXPECT_EQ(c.stamp.sequence, written[k].stamp.sequence);
  }
  EXPECT_EQ(k, written.size());
  EXPECT_EQ(reader.error(), "");
  msgs::PsdCommand wrong_family;
  hil::InputsLogReader again(path, log);
  EXPECT_FALSE(again.next(step, wrong_family));  // an ev log gives no psd command
}

// The series hybrid's commands: written and read back exactly; a gensetON other than 0 or 1 and
// a line with a field too few are refused with their line.
TEST(InputsLog, TheSeriesHybridsCommandsComeBackAndItsOnOffFlagIsChecked) {
  const std::string head = "# ehpt inputs log 1\n# scenario /x/shev.toml\n# family shev\n# pacing lockstep\n";
  std::string text = head;
  char line[256];
  std::vector<msgs::ShevCommand> written;
  for (int k = 0; k < 50; ++k) {
    msgs::ShevCommand c;
    c.stamp = msgs::Stamp{0.01 * k, 10 * k, static_cast<std::uint32_t>(k)};
    c.driveTauRef_Nm = 1.0 / (k + 3) - 0.17;
    c.gensetPowRef_W = k * 1234.5678;
    c.gensetON = k % 3 == 0;
    written.push_back(c);
    text += std::string(line, static_cast<std::size_t>(hil::format_command(line, sizeof line, 10 * k, c))) + "\n";
  }
  const std::string path = temp_log("shev.log", text);
  hil::InputsLog log;
  std::vector<std::string> problems;
  ASSERT_TRUE(hil::read_inputs_log(path, log, problems)) << problems.front();
  EXPECT_EQ(log.family, "shev");
  EXPECT_EQ(log.commands, 50);
  hil::InputsLogReader reader(path, log);
  std::int64_t step = -1;
  msgs::ShevCommand c;
  std::size_t k = 0;
  for (; reader.next(step, c); ++k) {
    ASSERT_LT(k, written.size());
    EXPECT_EQ(step, static_cast<std::int64_t>(10 * k));
    EXPECT_EQ(c.driveTauRef_Nm, written[k].driveTauRef_Nm);
    EXPECT_EQ(c.gensetPowRef_W, written[k].gensetPowRef_W);
    EXPECT_EQ(c.gensetON, written[k].gensetON) << k;
    EXPECT_EQ(c.stamp.sequence, written[k].stamp.sequence);
  }
  EXPECT_EQ(k, written.size());
  EXPECT_EQ(reader.error(), "");

  for (const auto& [bad, why] : std::vector<std::pair<std::string, std::string>>{
           {"shev 10 1 10 0.01 5 60000 2\n", ":5: gensetON must be 0 or 1"},
           {"shev 10 1 10 0.01 5 60000\n", ":5: expected 8 fields"}}) {
    hil::InputsLog bad_log;
    problems.clear();
    EXPECT_FALSE(hil::read_inputs_log(temp_log("bad_shev.log", head + bad), bad_log, problems)) << bad;
    ASSERT_FALSE(problems.empty()) << bad;
    EXPECT_NE(problems.front().find(why), std::string::npos) << problems.front();
  }
}

TEST(InputsLog, ALogChangedAfterItsCheckIsAnErrorOfTheReplay) {
  const std::string good = std::string(kHead) + "ev 0 0 0 0 1.5\nev 10 1 10 0.01 2.5\n";
  const std::string path = temp_log("changing.log", good);
  hil::InputsLog log;
  std::vector<std::string> problems;
  ASSERT_TRUE(hil::read_inputs_log(path, log, problems));
  std::int64_t step = 0;
  msgs::EvCommand c;
  {  // a value changed, same length and still well-formed: only the digest can tell
    temp_log("changing.log", std::string(kHead) + "ev 0 0 0 0 1.5\nev 10 1 10 0.01 3.5\n");
    hil::InputsLogReader reader(path, log);
    while (reader.next(step, c)) {
    }
    EXPECT_NE(reader.error().find("the log changed while it was replayed"), std::string::npos) << reader.error();
  }
  {  // a command that no longer parses
    temp_log("changing.log", std::string(kHead) + "ev 0 0 0 0 1.5\nev 10 1 10 0.01 nan\n");
    hil::InputsLogReader reader(path, log);
    EXPECT_TRUE(reader.next(step, c));
    EXPECT_FALSE(reader.next(step, c));
    EXPECT_NE(reader.error().find(path + ":8: 'nan' is not a finite number: the log changed after it was checked"),
              std::string::npos)
        << reader.error();
  }
  {  // steps that go back
    temp_log("changing.log", std::string(kHead) + "ev 20 0 0 0 1.5\nev 10 1 10 0.01 2.5\n");
    hil::InputsLogReader reader(path, log);
    EXPECT_TRUE(reader.next(step, c));
    EXPECT_FALSE(reader.next(step, c));
    EXPECT_NE(reader.error().find(path + ":8: a command that does not follow"), std::string::npos) << reader.error();
  }
  {  // gone
    fs::remove(path);
    hil::InputsLogReader reader(path, log);
    EXPECT_FALSE(reader.next(step, c));
    EXPECT_NE(reader.error().find("cannot open again"), std::string::npos) << reader.error();
  }
}

TEST(InputsLog, ParseInputsLineTakesExactlyTheFormat) {
  hil::InputsLogLine l;
  std::string why;
  ASSERT_TRUE(hil::parse_inputs_line("psd 5 4294967295 -3 0.5 1 2 3 4 1", l, why)) << why;
  EXPECT_EQ(l.family, "psd");
  EXPECT_EQ(l.step, 5);
  EXPECT_EQ(l.sequence, 4294967295u);
  EXPECT_EQ(l.stamp_step, -3);
  EXPECT_EQ(l.n_values, 6u);
  EXPECT_EQ(l.values[5], 1.0);
  ASSERT_TRUE(hil::parse_inputs_line("ev\t1\t2\t3  4.25e-3  -7", l, why)) << why;  // tabs, runs of blanks
  EXPECT_EQ(l.values[0], 4.25e-3);
  for (const char* bad : {"ev", "ev 1 2", "ev x 0 0 1 2", "ev 1 -1 0 1 2", "ev 1 2 3 inf", "ev 1 2 3 0x", "ev 1 2 3 1 2 3 4 5 6 7",
                          "ev 1 2 3 --1"}) {
    EXPECT_FALSE(hil::parse_inputs_line(bad, l, why)) << bad;
  }
}

// The header comes first: a --set or --fault line after a command would change what the
// commands above it were run with, so it is a problem of the log, with its line.
TEST(InputsLog, AHeaderLineAfterTheCommandsIsRefused) {
  for (const char* key : {"set a=3", "fault kind=drop target=EvCommand at_s=2"}) {
    const std::string text = std::string(kHead) + "ev 0 0 0 0 1.5\n# " + key + "\nev 10 1 10 0.01 1.5\n";
    hil::InputsLog log;
    std::vector<std::string> problems;
    EXPECT_FALSE(hil::read_inputs_log(temp_log("late_header.log", text), log, problems)) << key;
    ASSERT_EQ(problems.size(), 1u) << key;
    const std::string word = std::string(key).substr(0, std::string(key).find(' '));
    EXPECT_NE(problems[0].find(":8: '# " + word + "' after the commands"), std::string::npos) << problems[0];
  }
}

}  // namespace
}  // namespace ehpt
