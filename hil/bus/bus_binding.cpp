// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/bus_binding.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <set>

#include <toml++/toml.h>

#include "hil/config/scenario.hpp"
#include "hil/config/toml_guard.hpp"
#include "io/text_file.hpp"
#include "msgs/fields.hpp"

namespace ehpt::hil {

namespace {

using io::can::DbcMessage;
using io::can::DbcSignal;

constexpr std::size_t kMaxBoundMessages = 32;  // per direction
constexpr int kMaxReceivedFields = 64;         // the completion mask's bits

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// A field of the family by name: its index, kind and SI unit.
struct FieldInfo {
  int index = -1;
  msgs::FieldKind kind = msgs::FieldKind::kQuantity;
  std::string_view unit;
};
template <class M>
std::optional<FieldInfo> find_field(std::string_view name) {
  const auto& t = msgs::FieldTable<M>::kFields;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i].name == name) return FieldInfo{static_cast<int>(i), t[i].kind, t[i].unit};
  }
  return std::nullopt;
}
template <class M>
std::vector<std::string> field_names() {
  std::vector<std::string> out;
  for (const auto& f : msgs::FieldTable<M>::kFields) out.emplace_back(f.name);
  return out;
}

struct Family {
  std::optional<FieldInfo> (*output)(std::string_view);  // sensors
  std::optional<FieldInfo> (*input)(std::string_view);   // command
  std::vector<std::string> (*output_names)();
  std::vector<std::string> (*input_names)();
};
std::optional<Family> family_of(const std::string& family) {
  if (family == "psd") {
    return Family{find_field<msgs::PsdSensors>, find_field<msgs::PsdCommand>, field_names<msgs::PsdSensors>,
                  field_names<msgs::PsdCommand>};
  }
  if (family == "ev") {
    return Family{find_field<msgs::EvSensors>, find_field<msgs::EvCommand>, field_names<msgs::EvSensors>,
                  field_names<msgs::EvCommand>};
  }
  if (family == "shev") {
    return Family{find_field<msgs::ShevSensors>, find_field<msgs::ShevCommand>, field_names<msgs::ShevSensors>,
                  field_names<msgs::ShevCommand>};
  }
  return std::nullopt;
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// The reader: every problem with the binding file's line.
struct Reader {
  const std::string& file;
  std::vector<std::string>& errors;
  std::vector<std::string> warnings;

  std::string at(const toml::node* n) const {
    return n != nullptr && n->source().begin.line > 0 ? file + ":" + std::to_string(n->source().begin.line) : file;
  }
  void error(const toml::node* n, const std::string& what) { errors.push_back(at(n) + ": " + what); }
  void warn(const toml::node* n, const std::string& what) { warnings.push_back(at(n) + ": " + what); }
  static std::string hint(const std::string& word, const std::vector<std::string>& candidates) {
    const std::string c = closest_name(word, candidates);
    return c.empty() ? "" : "; did you mean `" + c + "`?";
  }
  // Keys of a table that nothing reads: an error with a hint (a typo must not pass silently).
  void only_keys(const toml::table& t, const std::vector<std::string>& known, const std::string& where) {
    for (const auto& [k, v] : t) {
      const std::string key(k.str());
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        error(&v, where + "unknown key `" + key + "`" + hint(key, known) + " (known: " + join(known) + ")");
      }
    }
  }
  const std::string* text(const toml::table& t, const char* key, const std::string& where, bool required) {
    const toml::node* n = t.get(key);
    if (n == nullptr) {
      if (required) error(&t, where + "`" + key + "` is missing");
      return nullptr;
    }
    if (!n->is_string()) {
      error(n, where + "`" + key + "` must be a string");
      return nullptr;
    }
    return &n->as_string()->get();
  }
};

struct LoadState {
  Reader& r;
  const Family& fam;
  const io::can::Dbc& dbc;
  Binding& b;
  double ecu_period_s;
  std::set<std::string> bound_inputs;      // command fields bound so far
  std::set<const DbcMessage*> used;        // a message bound once
  int received_fields = 0;
};

// The factor from the signal's unit (or the binding's `unit`) to the field's SI unit.
bool convert(LoadState& st, const toml::node* at, const std::string& where, const DbcSignal& s, msgs::FieldKind kind,
             std::string_view si, const std::string* unit_override, double& to_si) {
  const std::string unit = unit_override != nullptr ? *unit_override : s.unit;
  if (kind == msgs::FieldKind::kFlag || kind == msgs::FieldKind::kBits) {
    if (!unit.empty() && unit != "-") {
      st.r.error(at, where + "unit \"" + unit + "\": a " + (kind == msgs::FieldKind::kFlag ? "flag" : "bit set") +
                         " has no unit");
      return false;
    }
    to_si = 1.0;
    return true;
  }
  if (kind == msgs::FieldKind::kQuantity && unit.empty()) {
    st.r.warn(at, where + "the signal has no unit: taken as " + std::string(si) + " (give unit = \"...\" to say which)");
    to_si = 1.0;
    return true;
  }
  const std::optional<double> f = unit_to_si(unit, kind == msgs::FieldKind::kFraction ? "" : si);
  if (!f) {
    const std::string want = kind == msgs::FieldKind::kFraction ? "a fraction (\"\", \"-\", \"1\" or \"%\")"
                                                                : std::string(si) + " or a unit that converts to it";
    st.r.error(at, where + "unit \"" + unit + "\" does not convert to " + want +
                       (unit_override != nullptr ? "" : " (the DBC's unit; give unit = \"...\" if the DBC's is wrong)"));
    return false;
  }
  to_si = *f;
  return true;
}

const DbcSignal* find_signal(LoadState& st, const DbcMessage& m, const std::string& name, const toml::node* at,
                             const std::string& where) {
  if (const DbcSignal* s = m.signal(name)) return s;
  std::vector<std::string> names;
  for (const auto& s : m.signals) names.push_back(s.name);
  st.r.error(at, where + "no signal `" + name + "` in " + m.name + " (" + st.dbc.file + ":" + std::to_string(m.line) +
                     ")" + Reader::hint(name, names) + " (its signals: " + join(names) + ")");
  return nullptr;
}

// An integer signal of exactly `bits` bits for a role.
bool role_signal(LoadState& st, const DbcMessage& m, const toml::table& t, const char* key, BoundRole role,
                 BoundMessage& bm, const std::string& where) {
  const std::string* name = st.r.text(t, key, where, false);
  if (name == nullptr) return true;
  const DbcSignal* s = find_signal(st, m, *name, t.get(key), where);
  if (s == nullptr) return false;
  if (s->value_type != io::can::SignalValueType::kInteger || s->is_signed || s->factor != 1.0 || s->offset != 0.0 ||
      s->multiplex == io::can::Multiplex::kMultiplexed) {
    st.r.error(t.get(key), where + "`" + key + "` " + s->name +
                               ": must be an unsigned integer signal with factor 1 and offset 0, in every frame");
    return false;
  }
  if (role == BoundRole::kCounter && s->length > 16) {
    st.r.error(t.get(key), where + "counter " + s->name + ": " + std::to_string(s->length) + " bits (at most 16)");
    return false;
  }
  BoundSignal bs;
  bs.signal = s;
  bs.role = role;
  bs.raw = io::can::codec_raw_range(*s);
  bm.signals.push_back(bs);
  return true;
}

bool read_e2e(LoadState& st, const DbcMessage& m, const toml::node& node, BoundMessage& bm, const std::string& where) {
  const toml::table* t = node.as_table();
  if (t == nullptr) {
    st.r.error(&node, where + "`e2e` must be a table: e2e = { profile = \"P01\", data_id = 0x123, crc = \"...\", counter = \"...\" }");
    return false;
  }
  st.r.only_keys(*t, {"profile", "data_id", "data_id_list", "crc", "counter", "id_mode", "max_delta_counter"},
                 where + "e2e: ");
  io::can::E2eConfig c;
  const std::string* profile = st.r.text(*t, "profile", where + "e2e: ", true);
  if (profile == nullptr) return false;
  if (*profile == "P01") {
    c.profile = io::can::E2eProfile::kP01;
  } else if (*profile == "P02") {
    c.profile = io::can::E2eProfile::kP02;
  } else {
    st.r.error(t->get("profile"), where + "e2e: profile \"" + *profile + "\": must be \"P01\" (CRC-8 SAE J1850) or \"P02\" (CRC-8H2F)");
    return false;
  }
  c.length_bytes = m.size_bytes;
  const std::string* crc = st.r.text(*t, "crc", where + "e2e: ", true);
  const std::string* counter = st.r.text(*t, "counter", where + "e2e: ", true);
  if (crc == nullptr || counter == nullptr) return false;
  const DbcSignal* cs = find_signal(st, m, *crc, t->get("crc"), where + "e2e: ");
  const DbcSignal* ks = find_signal(st, m, *counter, t->get("counter"), where + "e2e: ");
  if (cs == nullptr || ks == nullptr) return false;
  // one whole byte: Intel from its bit 0, Motorola from its bit 7 (a Motorola start bit is the MSB)
  const int byte_start = cs->byte_order == io::can::ByteOrder::kIntel ? 0 : 7;
  if (cs->length != 8 || cs->start_bit % 8 != byte_start || cs->value_type != io::can::SignalValueType::kInteger) {
    st.r.error(t->get("crc"), where + "e2e: crc " + cs->name + " must be one whole byte (8 bits filling one byte)");
    return false;
  }
  if (ks->length != 4 || ks->start_bit % 4 != 0 || ks->byte_order != io::can::ByteOrder::kIntel) {
    st.r.error(t->get("counter"), where + "e2e: counter " + ks->name +
                                      " must be one nibble (4 Intel bits from a multiple of 4), as the E2E profiles lay it out");
    return false;
  }
  c.crc_byte = cs->start_bit / 8;
  c.counter_bit = ks->start_bit;
  if (const toml::node* n = t->get("max_delta_counter")) {
    const auto v = n->value<std::int64_t>();
    if (!v || *v < 1 || *v > 14) {
      st.r.error(n, where + "e2e: max_delta_counter must be an integer 1..14");
      return false;
    }
    c.max_delta_counter = static_cast<int>(*v);
  } else {
    c.max_delta_counter = 3;  // the same rule as ehpt's own counter (io/can/codec.hpp kMaxCounterJump)
  }
  if (c.profile == io::can::E2eProfile::kP01) {
    const toml::node* n = t->get("data_id");
    const auto v = n != nullptr ? n->value<std::int64_t>() : std::nullopt;
    if (!v || *v < 0 || *v > 0xFFFF) {
      st.r.error(n != nullptr ? n : t, where + "e2e: P01 needs data_id, an integer 0..0xFFFF");
      return false;
    }
    c.data_id = static_cast<std::uint16_t>(*v);
    if (const std::string* mode = st.r.text(*t, "id_mode", where + "e2e: ", false)) {
      if (*mode == "both") {
        c.id_mode = io::can::P01DataIdMode::kBoth;
      } else if (*mode == "alternating") {
        c.id_mode = io::can::P01DataIdMode::kAlternating;
      } else if (*mode == "low") {
        c.id_mode = io::can::P01DataIdMode::kLow;
      } else {
        st.r.error(t->get("id_mode"), where + "e2e: id_mode \"" + *mode + "\": must be both, alternating or low");
        return false;
      }
    }
  } else {
    const toml::node* n = t->get("data_id_list");
    const toml::array* a = n != nullptr ? n->as_array() : nullptr;
    if (a == nullptr || a->size() != 16) {
      st.r.error(n != nullptr ? n : t, where + "e2e: P02 needs data_id_list, 16 integers 0..255 (one per counter value)");
      return false;
    }
    for (std::size_t i = 0; i < 16; ++i) {
      const auto v = (*a)[i].value<std::int64_t>();
      if (!v || *v < 0 || *v > 255) {
        st.r.error(&(*a)[i], where + "e2e: data_id_list[" + std::to_string(i) + "] must be an integer 0..255");
        return false;
      }
      c.data_id_list[i] = static_cast<std::uint8_t>(*v);
    }
  }
  if (const char* why = io::can::e2e_config_problem(c); why != nullptr && *why != '\0') {
    st.r.error(&node, where + "e2e: " + why);
    return false;
  }
  bm.e2e = c;
  bm.e2e_signals = {cs, ks};
  return true;
}

void read_message(LoadState& st, const toml::table& t, bool send) {
  const std::string kind = send ? "[[send]]" : "[[receive]]";
  st.r.only_keys(t, {"message", "signals", "cycle_ms", "timeout_ms", "counter", "echo", "e2e"}, kind + ": ");
  const std::string* name = st.r.text(t, "message", kind + ": ", true);
  if (name == nullptr) return;
  const std::string where = kind + " " + *name + ": ";
  const DbcMessage* m = st.dbc.message(*name);
  if (m == nullptr) {
    std::vector<std::string> names;
    for (const auto& mm : st.dbc.messages) names.push_back(mm.name);
    st.r.error(t.get("message"), kind + ": no message `" + *name + "` in " + st.dbc.file + Reader::hint(*name, names));
    return;
  }
  if (!st.used.insert(m).second) {
    st.r.error(t.get("message"), where + "bound twice (each message once, in [[send]] or [[receive]])");
    return;
  }
  // direction: the DBC's senders say who sends it
  const bool plant_sends = std::find(m->senders.begin(), m->senders.end(), st.b.plant_node) != m->senders.end();
  if (send && !plant_sends) {
    st.r.error(t.get("message"), where + "the DBC says " + (m->senders.empty() ? "no node" : join(m->senders)) +
                                     " sends it (" + st.dbc.file + ":" + std::to_string(m->line) + "), not " +
                                     st.b.plant_node + ": the plant cannot send it (bind it in [[receive]]?)");
    return;
  }
  if (!send && plant_sends) {
    st.r.error(t.get("message"), where + "the DBC says " + st.b.plant_node + " sends it (" + st.dbc.file + ":" +
                                     std::to_string(m->line) + "): the plant cannot receive it (bind it in [[send]]?)");
    return;
  }
  if (m->size_bytes > 8 || m->fd) {
    st.r.error(t.get("message"), where + std::to_string(m->size_bytes) +
                                     " bytes (CAN FD): ehpt's transports carry classic CAN frames of up to 8 bytes");
    return;
  }
  if (send && m->multiplexor() != nullptr) {
    st.r.error(t.get("message"), where + "a multiplexed message can be received, not sent, by the plant");
    return;
  }
  BoundMessage bm;
  bm.message = m;
  bm.send = send;
  bm.line = t.source().begin.line;
  // cycle: the binding's, else the DBC's GenMsgCycleTime, else every sample
  if (const toml::node* n = t.get("cycle_ms")) {
    const auto v = n->value<std::int64_t>();
    if (n->is_string() && n->as_string()->get() == "sample") {
      bm.cycle_ms = 0;
    } else if (!v || *v < 1 || *v > 60000) {
      st.r.error(n, where + "cycle_ms must be an integer 1..60000, or \"sample\" (every ECU sample)");
      return;
    } else {
      bm.cycle_ms = static_cast<int>(*v);
    }
  } else if (m->cycle_time_ms) {
    bm.cycle_ms = *m->cycle_time_ms;
  }
  if (send && bm.cycle_ms > 0) {
    const double periods = bm.cycle_ms * 1e-3 / st.ecu_period_s;
    if (std::fabs(periods - std::round(periods)) > 1e-6 || periods < 0.5) {
      st.r.warn(t.get("message"), where + "cycle " + std::to_string(bm.cycle_ms) +
                                      " ms is not a whole number of ECU periods; it goes out at the first ECU sample "
                                      "after each cycle");
    }
  }
  if (const toml::node* n = t.get("timeout_ms")) {
    const auto v = n->value<double>();
    if (send) {
      st.r.error(n, where + "timeout_ms is of a received message");
    } else if (!v || !(*v > 0.0) || *v > 3.6e6) {
      st.r.error(n, where + "timeout_ms must be a number > 0 (ms)");
      return;
    } else {
      bm.timeout_s = *v * 1e-3;
    }
  } else if (!send) {
    bm.timeout_s = bm.cycle_ms > 0 ? 3.0 * bm.cycle_ms * 1e-3 : 0.0;  // 0: the plant's command timeout
  }
  if (send && t.get("echo") != nullptr) st.r.error(t.get("echo"), where + "echo is of a received message");
  if (!role_signal(st, *m, t, "counter", BoundRole::kCounter, bm, where)) return;
  if (!send && !role_signal(st, *m, t, "echo", BoundRole::kEcho, bm, where)) return;
  if (!send) {
    for (const auto& s : bm.signals) st.b.echo = st.b.echo || s.role == BoundRole::kEcho;
  }
  if (const toml::node* n = t.get("e2e")) {
    if (t.get("counter") != nullptr) {
      st.r.error(n, where + "e2e has its own counter: drop `counter`");
      return;
    }
    if (!read_e2e(st, *m, *n, bm, where)) return;
  }
  const toml::node* sn = t.get("signals");
  const toml::table* signals = sn != nullptr ? sn->as_table() : nullptr;
  if (signals == nullptr) {
    st.r.error(sn != nullptr ? sn : &t, where + "`signals` must be a table: signals = { DbcSignal = \"plant_field\", ... }");
    return;
  }
  std::set<const DbcSignal*> taken(bm.e2e_signals.begin(), bm.e2e_signals.end());
  for (const auto& bs : bm.signals) taken.insert(bs.signal);
  for (const auto& [key, value] : *signals) {
    const std::string sig_name(key.str());
    const DbcSignal* s = find_signal(st, *m, sig_name, &value, where);
    if (s == nullptr) continue;
    const std::string sw = where + sig_name + ": ";
    if (!taken.insert(s).second) {
      st.r.error(&value, sw + "bound twice in this message (or also its counter, echo or E2E signal)");
      continue;
    }
    std::string field;
    const std::string* unit = nullptr;
    if (value.is_string()) {
      field = value.as_string()->get();
    } else if (const toml::table* vt = value.as_table()) {
      st.r.only_keys(*vt, {"field", "unit"}, sw);
      const std::string* f = st.r.text(*vt, "field", sw, true);
      if (f == nullptr) continue;
      field = *f;
      unit = st.r.text(*vt, "unit", sw, false);
    } else {
      st.r.error(&value, sw + "must be a plant field's name, or { field = \"...\", unit = \"...\" }");
      continue;
    }
    BoundSignal b;
    b.signal = s;
    b.raw = io::can::codec_raw_range(*s);
    std::optional<FieldInfo> fi;
    if (send && field == "plant_step") {
      b.role = BoundRole::kPlantStep;
      fi = FieldInfo{-1, msgs::FieldKind::kBits, ""};
    } else if (send && field == "ecu_timeout") {
      b.role = BoundRole::kEcuTimeout;
      fi = FieldInfo{-1, msgs::FieldKind::kFlag, ""};
    } else {
      fi = send ? st.fam.output(field) : st.fam.input(field);
      if (!fi) {
        std::vector<std::string> names = send ? st.fam.output_names() : st.fam.input_names();
        if (send) names.insert(names.end(), {"plant_step", "ecu_timeout"});
        const bool other_way = (send ? st.fam.input(field) : st.fam.output(field)).has_value();
        st.r.error(&value, sw + "`" + field + "` is not " + (send ? "an output" : "an input") + " of the " +
                               st.b.family + " plant" +
                               (other_way ? std::string(" (it is ") + (send ? "an input: bind it in [[receive]])" : "an output: bind it in [[send]])")
                                          : Reader::hint(field, names)) +
                               " (its " + (send ? "outputs" : "inputs") + ": " + join(names) + ")");
        continue;
      }
      b.field = fi->index;
    }
    if (!convert(st, &value, sw, *s, fi->kind, fi->unit, unit, b.to_si)) continue;
    if (!send) {
      if (!st.bound_inputs.insert(field).second) {
        st.r.error(&value, sw + "plant input `" + field + "` is bound twice (each input to one signal)");
        continue;
      }
      if (st.received_fields >= kMaxReceivedFields) {
        st.r.error(&value, sw + "more than " + std::to_string(kMaxReceivedFields) + " received fields");
        continue;
      }
      b.mask_bit = std::uint64_t{1} << st.received_fields++;
      st.b.complete_mask |= b.mask_bit;
    }
    bm.signals.push_back(b);
  }
  if (!send && std::none_of(bm.signals.begin(), bm.signals.end(),
                            [](const BoundSignal& s) { return s.role == BoundRole::kField; })) {
    // nothing of it would be waited for: its timeout could never start, nor a command need it
    st.r.error(&t, where + "binds no plant input (give it signals = { DbcSignal = \"input\" }, or leave it out)");
    return;
  }
  auto& list = send ? st.b.send : st.b.receive;
  if (list.size() >= kMaxBoundMessages) {
    st.r.error(&t, where + "more than " + std::to_string(kMaxBoundMessages) + " messages in one direction");
    return;
  }
  list.push_back(std::move(bm));
}

}  // namespace

std::optional<double> unit_to_si(std::string_view unit_in, std::string_view si) {
  const std::string u = lower(unit_in);
  struct Unit {
    const char* name;
    const char* si;
    double factor;
  };
  static const Unit kUnits[] = {
      {"rad/s", "rad/s", 1.0}, {"rpm", "rad/s", std::numbers::pi / 30.0}, {"1/min", "rad/s", std::numbers::pi / 30.0},
      {"u/min", "rad/s", std::numbers::pi / 30.0}, {"min-1", "rad/s", std::numbers::pi / 30.0}, {"r/min", "rad/s", std::numbers::pi / 30.0},
      {"m/s", "m/s", 1.0}, {"km/h", "m/s", 1.0 / 3.6}, {"kph", "m/s", 1.0 / 3.6}, {"kmh", "m/s", 1.0 / 3.6},
      {"mph", "m/s", 0.44704}, {"w", "W", 1.0}, {"kw", "W", 1000.0}, {"nm", "Nm", 1.0}, {"n.m", "Nm", 1.0},
      {"n*m", "Nm", 1.0}, {"n m", "Nm", 1.0}, {"knm", "Nm", 1000.0}, {"v", "V", 1.0}, {"mv", "V", 1e-3},
      {"a", "A", 1.0}, {"ma", "A", 1e-3}, {"", "", 1.0}, {"-", "", 1.0}, {"1", "", 1.0}, {"%", "", 0.01},
  };
  for (const Unit& k : kUnits) {
    if (u == k.name && si == k.si) return k.factor;
  }
  return std::nullopt;
}

std::vector<std::uint32_t> Binding::receive_ids() const {
  std::vector<std::uint32_t> ids;
  for (const auto& m : receive) ids.push_back(m.message->id | (m.message->extended ? io::can::kExtendedIdFlag : 0u));
  return ids;
}

namespace {

// The binding file as TOML (start-up), or nullopt with its line.
std::optional<toml::table> parse_toml(std::string_view text, const std::string& file, std::vector<std::string>& errors) {
  if (const int line = line_with_too_many_dots(text); line != 0) {
    errors.push_back(file + ":" + std::to_string(line) + ": more than " + std::to_string(kMaxDotsPerLine) +
                     " dots on one line");
    return std::nullopt;
  }
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    errors.push_back(file + ":" + std::to_string(e.source().begin.line) + ": TOML syntax: " + std::string(e.description()));
  }
  return std::nullopt;
}

// The binding's tables against its DBC's text.
std::optional<Binding> from_table(const toml::table& root, const std::string& binding_file, std::string_view dbc_text,
                                  const std::string& dbc_file, const std::string& family, double ecu_period_s,
                                  std::vector<std::string>& errors) {
  const std::size_t errors_before = errors.size();
  const std::optional<Family> fam = family_of(family);
  if (!fam) {
    errors.push_back(binding_file + ": family `" + family + "` has no bus messages (psd, ev or shev)");
    return std::nullopt;
  }
  Binding b;
  b.file = binding_file;
  b.family = family;
  b.dbc = io::can::parse_dbc(dbc_text, dbc_file);
  for (const auto& p : b.dbc.errors) errors.push_back(io::can::to_string(b.dbc, p));
  for (const auto& p : b.dbc.warnings) b.warnings.push_back(io::can::to_string(b.dbc, p));
  if (!b.dbc.ok()) return std::nullopt;
  Reader r{binding_file, errors, {}};
  r.only_keys(root, {"dbc", "plant_node", "send", "receive", "unbound"}, "");
  const std::string* node = r.text(root, "plant_node", "", true);
  if (node == nullptr) return std::nullopt;
  b.plant_node = *node;
  if (std::find(b.dbc.nodes.begin(), b.dbc.nodes.end(), b.plant_node) == b.dbc.nodes.end()) {
    r.error(root.get("plant_node"), "plant_node `" + b.plant_node + "` is not a node of " + dbc_file +
                                        Reader::hint(b.plant_node, b.dbc.nodes) + " (its nodes: " + join(b.dbc.nodes) + ")");
    return std::nullopt;
  }
  LoadState st{r, *fam, b.dbc, b, ecu_period_s, {}, {}, 0};
  for (const char* dir : {"send", "receive"}) {
    const toml::node* n = root.get(dir);
    if (n == nullptr) {
      r.error(&root, std::string("no [[") + dir + "]] table: the plant must " + (dir[0] == 's' ? "send" : "receive") +
                         " at least one message");
      continue;
    }
    const toml::array* a = n->as_array();
    if (a == nullptr || !a->is_array_of_tables()) {
      r.error(n, std::string("`") + dir + "` must be an array of tables ([[" + dir + "]])");
      continue;
    }
    for (const auto& e : *a) read_message(st, *e.as_table(), dir[0] == 's');
  }
  // every plant input: bound, or given a value in [unbound]
  const toml::node* un = root.get("unbound");
  const toml::table* unbound = un != nullptr ? un->as_table() : nullptr;
  if (un != nullptr && unbound == nullptr) r.error(un, "[unbound] must be a table: field = value");
  if (unbound != nullptr) {
    for (const auto& [k, v] : *unbound) {
      const std::string field(k.str());
      const std::optional<FieldInfo> fi = fam->input(field);
      if (!fi) {
        r.error(&v, "[unbound] `" + field + "` is not an input of the " + family + " plant" +
                        Reader::hint(field, fam->input_names()) + " (its inputs: " + join(fam->input_names()) + ")");
        continue;
      }
      if (st.bound_inputs.count(field) != 0) {
        r.error(&v, "[unbound] `" + field + "` is bound to a signal: it cannot also have a fixed value");
        continue;
      }
      std::optional<double> value = v.value<double>();
      if (v.is_boolean()) value = v.as_boolean()->get() ? 1.0 : 0.0;
      if (!value || !std::isfinite(*value)) {
        r.error(&v, "[unbound] `" + field + "` must be a finite number (or true/false for a flag)");
        continue;
      }
      b.unbound.emplace_back(fi->index, *value);
      st.bound_inputs.insert(field);
    }
  }
  for (const auto& name : fam->input_names()) {
    if (st.bound_inputs.count(name) == 0) {
      r.error(&root, "plant input `" + name + "` is neither bound to a signal nor given a value in [unbound] (" + name +
                         " = ...)");
    }
  }
  b.warnings.insert(b.warnings.end(), r.warnings.begin(), r.warnings.end());
  if (errors.size() != errors_before) return std::nullopt;
  return std::optional<Binding>(std::move(b));  // moved: the pointers into b.dbc stay valid
}

}  // namespace

std::optional<Binding> parse_binding(std::string_view binding_text, const std::string& binding_file,
                                     std::string_view dbc_text, const std::string& dbc_file, const std::string& family,
                                     double ecu_period_s, std::vector<std::string>& errors) {
  const std::optional<toml::table> root = parse_toml(binding_text, binding_file, errors);
  if (!root) return std::nullopt;
  return from_table(*root, binding_file, dbc_text, dbc_file, family, ecu_period_s, errors);
}

std::optional<Binding> load_binding(const std::string& path, const std::string& family, double ecu_period_s,
                                    std::vector<std::string>& errors) {
  std::string text, reason;
  if (!io::read_text_file(path, text, reason)) {
    errors.push_back(path + ": " + reason);
    return std::nullopt;
  }
  const std::optional<toml::table> root = parse_toml(text, path, errors);
  if (!root) return std::nullopt;
  const toml::node* d = root->get("dbc");
  if (d == nullptr || !d->is_string() || d->as_string()->get().empty()) {
    errors.push_back((d != nullptr ? path + ":" + std::to_string(d->source().begin.line) : path) +
                     ": `dbc` must name the DBC file this binding's names are in (dbc = \"my_ecu.dbc\", relative to "
                     "the binding's folder)");
    return std::nullopt;
  }
  const std::string dbc_name = d->as_string()->get();
  const std::filesystem::path dbc_path = std::filesystem::path(path).parent_path() / dbc_name;
  std::string dbc_text;
  if (!io::read_text_file(dbc_path.string(), dbc_text, reason)) {
    errors.push_back(path + ":" + std::to_string(d->source().begin.line) + ": dbc = \"" + dbc_name + "\": " +
                     dbc_path.string() + ": " + reason);
    return std::nullopt;
  }
  return from_table(*root, path, dbc_text, dbc_path.string(), family, ecu_period_s, errors);
}

std::optional<Binding> default_binding(const std::string& family, double ecu_period_s, std::vector<std::string>& errors) {
  return parse_binding(builtin_binding_text(family), "<built-in ehpt-" + family + ".binding.toml>", builtin_ehpt_dbc(),
                       "<built-in ehpt.dbc>", family, ecu_period_s, errors);
}

}  // namespace ehpt::hil
