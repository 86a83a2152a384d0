// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A guard in front of toml++ (start-up only). toml++ 3.3 recurses once per part of a dotted
// key (a.b.c = 1, [a.b.c], {a.b.c = 1}) with no limit, so a key of ~31 000 parts - a 62 kB
// line - overflows an 8 MiB stack (found by tests/fuzz). A key cannot span lines, so a line
// with more than kMaxDotsPerLine dots is refused before toml++ sees it: 1000 parts recurse
// harmlessly, and no sensible scenario or vehicle file has that many dots on one line
// (cycles and maps are CSV files). Nesting of arrays and inline tables is limited by toml++
// itself (256).

#include <string_view>

namespace ehpt::hil {

inline constexpr int kMaxDotsPerLine = 1000;

// 0 if every line of the TOML text has at most kMaxDotsPerLine dots, else the 1-based line of
// the first that has more.
inline int line_with_too_many_dots(std::string_view text) {
  int line = 1, dots = 0;
  for (char c : text) {
    if (c == '\n') {
      ++line;
      dots = 0;
    } else if (c == '.' && ++dots > kMaxDotsPerLine) {
      return line;
    }
  }
  return 0;
}

}  // namespace ehpt::hil
