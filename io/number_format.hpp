// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Text for numbers in outputs: the shortest decimal that reads back to the same double, so
// a CSV is exact and two identical runs give byte-identical files.

#include <cstdint>
#include <string>

namespace ehpt::io {

// Appends the number to out; NaN/Inf as "nan", "inf", "-inf".
void append_number(std::string& out, double value);
std::string number_text(double value);
// Strict parse of a whole field (surrounding spaces allowed): false if anything else is there.
bool parse_number(const std::string& text, double& value);

// Run-phase text for the bus logs and the socketcand protocol: each writes at p and returns
// the end; no allocation, locale or printf (snprintf was half of a lockstep period's
// instructions). The caller's buffer must hold the longest result (put_number: 24 chars).
char* put_uint(char* p, std::uint64_t v);                // decimal: "0", "4294967295"
char* put_int(char* p, std::int64_t v);                  // decimal with '-' if negative
char* put_hex(char* p, std::uint32_t v, int min_digits); // upper case, zero padded to min_digits
char* put_seconds_us(char* p, std::int64_t us);          // "S.UUUUUU" (us >= 0): what "%lld.%06lld" prints
char* put_number(char* p, double value);                 // append_number's text (shortest round trip)

}  // namespace ehpt::io
