// SPDX-License-Identifier: BSD-3-Clause
#include "hil/diag/provenance.hpp"

#include "io/sha256.hpp"

namespace ehpt::hil {

std::string version_text() {
  const BuildInfo& b = build_info();
  std::string s = "ehpt " + std::string(b.version);
  s += b.git.empty() ? " (not built from a git checkout)\n" : " (git " + std::string(b.git) + ")\n";
  s += "compiler: " + std::string(b.compiler) + "\n";
  s += "build type: " + std::string(b.build_type) + "\n";
  s += "flags: " + std::string(b.flags) + "\n";
  return s;
}

std::string run_id(const std::vector<InputFile>& inputs, const std::vector<std::string>& set_texts,
                   const std::string& commands) {
  // a text that names every byte the run depends on
  std::string text = "ehpt-run-id 1\n";
  for (const InputFile& f : inputs) text += "input " + f.sha256 + " " + std::to_string(f.bytes) + "\n";
  for (const std::string& s : set_texts) text += "set " + s + "\n";
  if (!commands.empty()) text += "commands " + commands + "\n";
  return io::sha256_hex(text);
}

io::JsonObject provenance_json(const Scenario& sc, const CommandSource& commands) {
  const BuildInfo& b = build_info();
  io::JsonObject j;
  j.text("ehpt_version", std::string(b.version));
  if (b.git.empty()) {
    j.null("git");
  } else {
    j.text("git", std::string(b.git));
  }
  j.text("compiler", std::string(b.compiler));
  j.text("build_type", std::string(b.build_type));
  j.text("flags", std::string(b.flags));
  std::vector<InputFile> files = sc.inputs;
  files.insert(files.end(), commands.inputs.begin(), commands.inputs.end());
  std::vector<io::JsonObject> inputs;
  for (const InputFile& f : files) {
    io::JsonObject i;
    i.text("path", f.path);
    i.text("sha256", f.sha256);
    i.integer("bytes", static_cast<long long>(f.bytes));
    inputs.push_back(std::move(i));
  }
  j.objects("inputs", inputs);
  j.strings("overrides", sc.overrides);
  j.text("commands", commands.kind.empty() ? "built-in ECU" : commands.description);
  j.text("run_id", run_id(files, sc.overrides, commands.kind));
  return j;
}

}  // namespace ehpt::hil
