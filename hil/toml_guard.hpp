#pragma once
// A guard in front of toml++ (start-up only). toml++ 3.3 recurses once per part of a dotted
// key (a.b.c = 1, [a.b.c]) with no limit, so a key of ~31 000 parts - a 62 kB line - overflows
// an 8 MiB stack (found by tests/fuzz). Nesting of arrays and inline tables is already
// limited by toml++ itself (256).

#include <cstddef>
#include <string_view>

namespace ehpt::hil {

inline constexpr int kMaxDottedKeyParts = 64;

// Returns 0 if every key in the TOML text has at most kMaxDottedKeyParts parts, else the
// 1-based line of the first that has more. Conservative: dots inside quoted key parts count.
inline int line_of_overlong_key(std::string_view text) {
  int line = 1;
  std::size_t at = 0;
  while (at <= text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(at, end - at);
    std::size_t b = 0;
    while (b < l.size() && (l[b] == ' ' || l[b] == '\t')) ++b;
    l.remove_prefix(b);
    std::string_view key;
    const std::size_t eq = l.find('=');
    if (!l.empty() && l[0] == '[') {
      // a table header [a.b] or [[a.b]]; not the continuation of a multi-line array
      std::size_t k = l.size() > 1 && l[1] == '[' ? 2 : 1;
      const char c = k < l.size() ? l[k] : '\0';
      const bool header = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == '"' || c == '\'';
      if (header) key = l.substr(0, l.find(']', k));
    } else if (eq != std::string_view::npos) {
      key = l.substr(0, eq);
    }
    int parts = 1;
    for (char ch : key) parts += ch == '.' ? 1 : 0;
    if (parts > kMaxDottedKeyParts) return line;
    if (end == text.size()) break;
    at = end + 1;
    ++line;
  }
  return 0;
}

}  // namespace ehpt::hil
