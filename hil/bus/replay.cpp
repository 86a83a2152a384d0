// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/replay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "hil/run/port.hpp"
#include "hil/run/simulation.hpp"
#include "io/json_value.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

namespace {

// The link figures of a recorded session: bus.timeouts and bus.safe_state_time_s of the
// summary.json beside its inputs.log; NaN if there is none to read.
LinkFigures session_link_figures(const std::string& log_path) {
  LinkFigures f{NAN, NAN};
  const std::size_t slash = log_path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : log_path.substr(0, slash);
  std::string text, reason, error;
  io::JsonValue v;
  if (!io::read_text_file(dir + "/summary.json", text, reason) || !io::parse_json(text, v, error)) return f;
  const io::JsonValue* bus = v.find("bus");
  if (bus == nullptr) return f;
  const auto number = [&](const char* key) {
    const io::JsonValue* x = bus->find(key);
    return x != nullptr && x->kind == io::JsonValue::Kind::kNumber ? std::strtod(x->text.c_str(), nullptr) : NAN;
  };
  f.ecu_timeouts = number("timeouts");
  f.safe_state_s = number("safe_state_time_s");
  return f;
}

// A recorded session as the runner's ECU port: each record acts from the step it acted from
// in the session, in the same place of the same loop (hil/run/port.hpp) as the bus plant
// applied it; as fast as possible (no pacer). No sample goes anywhere.
template <class Sensors, class Command>
class ReplayDriver final : public ExternalDriver, public EcuPort<Sensors, Command> {
 public:
  ReplayDriver(const InputsLog& log, std::string log_path)
      : log_(log), log_path_(std::move(log_path)), reader_(log_path_, log) {
    has_next_ = reader_.next(next_step_, next_);
    link_ = session_link_figures(log_path_);
  }

  bool open(const io::OutputDir&, std::string&) override { return true; }

  void start(Simulation& sim, const std::atomic<int>*) override {
    if (!sim.attach(this, nullptr)) attach_error_ = log_path_ + ": its family (" + log_.family + ") is not this vehicle's";
  }

  bool commands_due(std::int64_t n, Command& command) override {
    bool applied = false;
    while (has_next_ && next_step_ <= n) {  // the log streamed: one command ahead
      command = next_;
      ++applied_;
      applied = true;
      has_next_ = reader_.next(next_step_, next_);
    }
    return applied;
  }
  bool sample(std::int64_t, const Sensors&, Command&) override { return false; }

  bool flush(std::string& error) override {
    if (!attach_error_.empty()) error = attach_error_;
    if (attach_error_.empty() && !reader_.error().empty()) error = reader_.error();
    return error.empty();
  }

  // The end: the rest of the log is read too (not applied: the session stopped there), so
  // that a log changed while it was replayed is caught by its SHA-256 in every case.
  bool finish(std::string& error) override {
    std::int64_t step = 0;
    Command c{};
    while (reader_.next(step, c)) {
    }
    return flush(error);
  }

  // inputs.log holds the commands as the plant applied them, bus faults and all: a replay
  // reproduces a faulted session without acting them out again
  bool takes_bus_faults() const override { return true; }
  // the session's own (its summary.json beside inputs.log): the timeouts are the plant's
  // judgement of the wall clock, which a replay does not have
  LinkFigures link_figures() const override { return link_; }
  CommandSource command_source() const override {
    InputFile f = log_.file;
    f.path = log_path_;
    return {"replay", "replay of " + log_path_, {f}};
  }

  void report(io::JsonObject& summary, std::string& text) const override {
    io::JsonObject r;
    r.text("inputs_log", log_path_);
    r.text("recorded_pacing", log_.pacing);
    r.integer("commands_recorded", log_.commands);
    r.integer("commands_applied", applied_);
    summary.object("replay", r);
    text += "replay        " + std::to_string(applied_) + " of " + std::to_string(log_.commands) +
            " recorded commands applied (" + log_.pacing + " session, " + log_path_ + ")\n";
  }

 private:
  const InputsLog& log_;
  std::string log_path_;
  InputsLogReader reader_;
  bool has_next_ = false;
  std::int64_t next_step_ = 0;
  Command next_{};
  std::int64_t applied_ = 0;
  std::string attach_error_;
  LinkFigures link_;
};

}  // namespace

std::unique_ptr<ExternalDriver> make_replay_driver(const InputsLog& log, const std::string& log_path) {
  if (log.family == "psd") {
    return std::make_unique<ReplayDriver<msgs::PsdSensors, msgs::PsdCommand>>(log, log_path);
  }
  if (log.family == "shev") {
    return std::make_unique<ReplayDriver<msgs::ShevSensors, msgs::ShevCommand>>(log, log_path);
  }
  return std::make_unique<ReplayDriver<msgs::EvSensors, msgs::EvCommand>>(log, log_path);
}

}  // namespace ehpt::hil
