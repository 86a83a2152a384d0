// SPDX-License-Identifier: BSD-3-Clause
// `ehpt dbc`: check a DBC file as ehpt reads it, list its messages and signals, and decode
// frames with it (io/can/dbc.hpp), to see what a binding will see before a session runs.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "io/can/candump_log.hpp"
#include "io/can/dbc.hpp"
#include "io/json_writer.hpp"
#include "io/number_format.hpp"
#include "targets/cli.hpp"

namespace ehpt::cli {

namespace {

namespace can = ehpt::io::can;

const char* kDbcHelp =
    "usage: ehpt dbc FILE.dbc [--json] [FRAME ...] [--frames PATH]\n"
    "Reads a DBC file as ehpt does and reports every problem as FILE:LINE (exit 2 if any):\n"
    "signals outside their payload, ids too long for their format, unsupported statements.\n"
    "Without frames: lists the messages (id, size, sender, cycle time, send type) and their\n"
    "signals (bits, byte order, scaling, range, unit, multiplexing).\n"
    "With frames: decodes each, one line per frame, the signals present in it (a multiplexed\n"
    "signal only when its multiplexor selects it).\n"
    "\n"
    "  FRAME          candump's form: ID#DATA (classic CAN) or ID##FDATA (CAN FD, F the flags\n"
    "                 nibble); ID is hex, 3 digits standard, 8 digits extended (or above 0x7FF)\n"
    "  --frames PATH  frames one per line from PATH ('-': standard input); a candump log\n"
    "                 line '(time) iface ID#DATA' is read too\n"
    "  --json         the list as one JSON object; decoded frames as one JSON object per line\n";

std::string hex_id(const can::DbcMessage& m) {
  char buf[16];
  std::snprintf(buf, sizeof buf, m.extended ? "0x%08X" : "0x%03X", static_cast<unsigned>(m.id));
  return buf;
}

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string number(double v) { return ehpt::io::number_text(v); }

std::string order_text(const can::DbcSignal& s) { return s.byte_order == can::ByteOrder::kIntel ? "Intel" : "Motorola"; }

std::string type_text(const can::DbcSignal& s) {
  if (s.value_type == can::SignalValueType::kFloat32) return "float";
  if (s.value_type == can::SignalValueType::kFloat64) return "double";
  return s.is_signed ? "signed" : "unsigned";
}

std::string mux_text(const can::DbcSignal& s) {
  if (s.multiplex == can::Multiplex::kMultiplexor) return "M";
  if (s.multiplex == can::Multiplex::kMultiplexed) return "m" + std::to_string(s.multiplex_value);
  return "";
}

ehpt::io::JsonObject message_json(const can::DbcMessage& m) {
  ehpt::io::JsonObject o;
  o.text("name", m.name);
  o.integer("id", m.id);
  o.boolean("extended", m.extended);
  o.boolean("fd", m.fd);
  o.integer("size_bytes", m.size_bytes);
  o.strings("senders", m.senders);
  if (m.cycle_time_ms) {
    o.integer("cycle_time_ms", *m.cycle_time_ms);
  } else {
    o.null("cycle_time_ms");
  }
  o.text("send_type", m.send_type);
  o.text("comment", m.comment);
  std::vector<ehpt::io::JsonObject> signals;
  for (const can::DbcSignal& s : m.signals) {
    ehpt::io::JsonObject j;
    j.text("name", s.name);
    j.integer("start_bit", s.start_bit);
    j.integer("length", s.length);
    j.text("byte_order", order_text(s));
    j.text("type", type_text(s));
    j.number("factor", s.factor);
    j.number("offset", s.offset);
    j.number("min", s.min);
    j.number("max", s.max);
    j.text("unit", s.unit);
    j.strings("receivers", s.receivers);
    j.text("multiplex", mux_text(s));
    if (s.start_value_raw) {
      j.number("start_value_raw", *s.start_value_raw);
    } else {
      j.null("start_value_raw");
    }
    std::vector<ehpt::io::JsonObject> names;
    for (const auto& v : s.value_names) {
      ehpt::io::JsonObject n;
      n.integer("raw", v.raw);
      n.text("name", v.name);
      names.push_back(n);
    }
    j.objects("value_names", names);
    j.text("comment", s.comment);
    signals.push_back(j);
  }
  o.objects("signals", signals);
  return o;
}

std::string message_text(const can::DbcMessage& m) {
  std::string t = hex_id(m) + " " + m.name + ": " + std::to_string(m.size_bytes) + " bytes" + (m.fd ? ", CAN FD" : "") +
                  ", from " + join(m.senders) +
                  (m.cycle_time_ms ? ", every " + std::to_string(*m.cycle_time_ms) + " ms" : ", no cycle time") +
                  (m.send_type.empty() ? "" : " (" + m.send_type + ")") + "\n";
  for (const can::DbcSignal& s : m.signals) {
    t += "  " + s.name + (s.multiplex == can::Multiplex::kNone ? "" : " [" + mux_text(s) + "]") + ": bit " +
         std::to_string(s.start_bit) + ", " + std::to_string(s.length) + (s.length == 1 ? " bit " : " bits ") + order_text(s) + " " + type_text(s) +
         ", factor " + number(s.factor) + (s.offset != 0.0 ? ", offset " + number(s.offset) : "") +
         (s.has_range() ? ", [" + number(s.min) + ", " + number(s.max) + "]" : "") +
         (s.unit.empty() ? "" : " " + s.unit) + "\n";
  }
  return t;
}

struct ParsedFrame {
  std::uint32_t id = 0;
  bool extended = false;
  std::vector<std::uint8_t> data;
};

// ID#DATA or ID##FDATA, optionally after candump's "(time) iface"; "" or the problem
std::string parse_frame(std::string text, ParsedFrame& f) {
  while (!text.empty() && (text.back() == '\r' || text.back() == ' ')) text.pop_back();
  const std::size_t space = text.rfind(' ');
  if (space != std::string::npos) text = text.substr(space + 1);  // the frame is the last field
  const std::size_t hash = text.find('#');
  if (hash == std::string::npos || hash == 0 || hash > 8) return "expected ID#DATA (hex), as candump writes it";
  std::uint32_t id = 0;
  for (std::size_t i = 0; i < hash; ++i) {
    const int d = can::hex_digit_value(text[i]);
    if (d < 0) return "the id '" + text.substr(0, hash) + "' is not hex";
    id = id * 16 + static_cast<std::uint32_t>(d);
  }
  f.extended = hash == 8 || id > 0x7FF;
  if (id > can::kMaxExtendedId) return "the id has more than 29 bits";
  f.id = id;
  std::size_t at = hash + 1;
  if (at < text.size() && text[at] == '#') {  // CAN FD: a flags nibble first
    at += 2;
    if (at > text.size()) return "a CAN FD frame (##) needs its flags digit";
  }
  const std::string data = text.substr(std::min(at, text.size()));
  if (data.size() % 2 != 0) return "the data has an odd number of hex digits";
  if (data.size() / 2 > static_cast<std::size_t>(can::kMaxDbcPayloadBytes)) return "more than 64 data bytes";
  f.data.clear();
  for (std::size_t i = 0; i < data.size(); i += 2) {
    const int hi = can::hex_digit_value(data[i]), lo = can::hex_digit_value(data[i + 1]);
    if (hi < 0 || lo < 0) return "the data '" + data + "' is not hex";
    f.data.push_back(static_cast<std::uint8_t>(hi * 16 + lo));
  }
  return "";
}

// the signal's raw value as its type reads it: sign-extended for signed integers
long long signed_raw(const can::DbcSignal& s, std::uint64_t raw) {
  if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1u)) {
    return static_cast<long long>(raw | (~std::uint64_t{0} << s.length));
  }
  return static_cast<long long>(raw);
}

std::string decode_line(const can::DbcMessage& m, const ParsedFrame& f, bool json) {
  std::string values;  // the signals' {"raw": r, "value": v} by name, on one line
  std::string t = hex_id(m) + " " + m.name + ":";
  bool first = true;
  for (const can::DbcSignal& s : m.signals) {
    if (!can::is_present(m, s, f.data)) continue;
    const std::uint64_t raw = can::extract_raw(s, f.data);
    const double value = can::raw_to_physical(s, raw);
    if (json) {
      ehpt::io::JsonObject v;
      v.number("value", value);
      std::string entry = v.compact();
      if (s.value_type == can::SignalValueType::kInteger) {  // exact, also above 2^63: digits, not a double
        const std::string digits = s.is_signed ? std::to_string(signed_raw(s, raw)) : std::to_string(raw);
        entry = "{\"raw\": " + digits + ", " + entry.substr(1);
      }
      values += (values.empty() ? "" : ", ") + ehpt::io::json_escape(s.name) + ": " + entry;
      continue;
    }
    t += std::string(first ? " " : ", ") + s.name + " = " + number(value) + (s.unit.empty() ? "" : " " + s.unit);
    for (const auto& n : s.value_names) {
      if (s.value_type == can::SignalValueType::kInteger && n.raw == signed_raw(s, raw)) t += " \"" + n.name + "\"";
    }
    first = false;
  }
  if (!json) return t + "\n";
  return "{\"id\": " + std::to_string(m.id) + ", \"extended\": " + (m.extended ? "true" : "false") +
         ", \"message\": " + ehpt::io::json_escape(m.name) + ", \"signals\": {" + values + "}}\n";
}

}  // namespace

int cmd_dbc(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kDbcHelp) ? 0 : 1;
  std::string path;
  bool json = false;
  std::vector<std::string> frames;
  std::string frames_path;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--json") {
      json = true;
    } else if (args[i] == "--frames") {
      if (i + 1 >= args.size()) {
        std::cerr << "error: --frames needs a path ('-': standard input)\n" << kDbcHelp;
        return 1;
      }
      frames_path = args[++i];
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::cerr << "error: unknown option " << args[i] << "\n" << kDbcHelp;
      return 1;
    } else if (path.empty()) {
      path = args[i];
    } else {
      frames.push_back(args[i]);
    }
  }
  if (path.empty()) {
    std::cerr << kDbcHelp;
    return 1;
  }
  const can::Dbc dbc = can::load_dbc(path);
  for (const auto& w : dbc.warnings) std::cerr << "warning: " << can::to_string(dbc, w) << "\n";
  for (const auto& e : dbc.errors) std::cerr << can::to_string(dbc, e) << "\n";
  if (!dbc.ok()) {
    std::cerr << "error: " << path << ": " << dbc.errors.size() << (dbc.errors.size() == 1 ? " problem" : " problems")
              << "; fix the DBC (nothing decoded)\n";
    return 2;
  }
  if (frames.empty() && frames_path.empty()) {
    std::string text;
    std::size_t signals = 0;
    for (const auto& m : dbc.messages) signals += m.signals.size();
    if (!json) {
      text = path + ": " + std::to_string(dbc.messages.size()) + " messages, " + std::to_string(signals) + " signals, " +
             std::to_string(dbc.nodes.size()) + " nodes\n";
    }
    if (json) {
      std::vector<ehpt::io::JsonObject> messages;
      for (const auto& m : dbc.messages) messages.push_back(message_json(m));
      ehpt::io::JsonObject o;
      o.text("file", path);
      o.text("version", dbc.version);
      o.strings("nodes", dbc.nodes);
      o.objects("messages", messages);
      text = o.str() + "\n";
    } else {
      for (const auto& m : dbc.messages) text += message_text(m);
    }
    return out(text) ? 0 : 1;
  }
  // Decoding: the frames of the command line, then those of --frames, streamed (a log of any
  // size is read a line at a time, its decoded lines written out as they gather)
  std::ifstream file;
  if (!frames_path.empty() && frames_path != "-") {
    file.open(frames_path);
    if (!file) {
      std::cerr << "error: --frames " << frames_path << ": cannot open it\n";
      return 2;
    }
  }
  std::string text;
  std::size_t seen = 0, bad = 0;
  const auto decode_one = [&](const std::string& frame) {
    ++seen;
    ParsedFrame f;
    std::string problem = parse_frame(frame, f);
    const can::DbcMessage* m = problem.empty() ? dbc.message(f.id, f.extended) : nullptr;
    if (problem.empty() && m == nullptr) problem = "no message of " + path + " has this id";
    if (m != nullptr && f.data.size() < static_cast<std::size_t>(m->size_bytes)) {
      problem = std::to_string(f.data.size()) + " data bytes; " + m->name + " has " + std::to_string(m->size_bytes);
    }
    if (!problem.empty()) {
      if (++bad <= 100) std::cerr << "frame " << seen << " '" << frame.substr(0, 200) << "': " << problem << "\n";
      return true;
    }
    text += decode_line(*m, f, json);
    if (text.size() < (1u << 16)) return true;
    const bool written = out(text);
    text.clear();
    return written;
  };
  for (const std::string& frame : frames) {
    if (!decode_one(frame)) return 1;
  }
  if (!frames_path.empty()) {
    std::istream& in = frames_path == "-" ? std::cin : file;
    for (std::string line; std::getline(in, line);) {
      if (line.find('#') == std::string::npos) continue;  // a candump log's other lines
      if (!decode_one(line)) return 1;
    }
  }
  if (!out(text)) return 1;
  if (bad > 0) {
    std::cerr << "error: " << bad << " of " << seen << " frames not decoded" << (bad > 100 ? " (the first 100 shown)" : "")
              << "\n";
    return 2;
  }
  if (seen == 0) {  // asked to decode, given nothing: not a success
    std::cerr << "error: --frames " << frames_path << ": no frame (ID#DATA) in it\n";
    return 2;
  }
  return 0;
}

}  // namespace ehpt::cli
