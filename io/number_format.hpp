// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Text for numbers in outputs: the shortest decimal that reads back to the same double, so
// a CSV is exact and two identical runs give byte-identical files.

#include <string>

namespace ehpt::io {

// Appends the number to out; NaN/Inf as "nan", "inf", "-inf".
void append_number(std::string& out, double value);
std::string number_text(double value);
// Strict parse of a whole field (surrounding spaces allowed): false if anything else is there.
bool parse_number(const std::string& text, double& value);

}  // namespace ehpt::io
