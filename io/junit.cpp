// SPDX-License-Identifier: BSD-3-Clause
#include "io/junit.hpp"

#include <cstdio>

namespace ehpt::io {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        if (u < 0x20 && c != '\t' && c != '\n' && c != '\r') {
          out += "\xEF\xBF\xBD";  // not allowed in XML 1.0, even escaped
        } else {
          out += c;
        }
    }
  }
  return out;
}

std::string junit_xml(const std::string& suite, const std::vector<JunitCase>& cases) {
  std::size_t failures = 0, errors = 0, skipped = 0;
  double total_s = 0.0;
  for (const JunitCase& c : cases) {
    failures += c.result == JunitCase::Result::kFailed ? 1 : 0;
    errors += c.result == JunitCase::Result::kError ? 1 : 0;
    skipped += c.result == JunitCase::Result::kSkipped ? 1 : 0;
    total_s += c.time_s;
  }
  const auto seconds = [](double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f", s);
    return std::string(buf);
  };
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x += "<testsuites tests=\"" + std::to_string(cases.size()) + "\" failures=\"" + std::to_string(failures) +
       "\" errors=\"" + std::to_string(errors) + "\" time=\"" + seconds(total_s) + "\">\n";
  x += "  <testsuite name=\"" + xml_escape(suite) + "\" tests=\"" + std::to_string(cases.size()) + "\" failures=\"" +
       std::to_string(failures) + "\" errors=\"" + std::to_string(errors) + "\" skipped=\"" + std::to_string(skipped) + "\" time=\"" +
       seconds(total_s) + "\">\n";
  for (const JunitCase& c : cases) {
    x += "    <testcase name=\"" + xml_escape(c.name) + "\" classname=\"" + xml_escape(c.classname) + "\" time=\"" +
         seconds(c.time_s) + "\"";
    if (c.result == JunitCase::Result::kPassed && c.details.empty()) {
      x += "/>\n";
      continue;
    }
    x += ">\n";
    if (c.result == JunitCase::Result::kSkipped) {
      x += "      <skipped message=\"" + xml_escape(c.message) + "\"/>\n";
    } else if (c.result != JunitCase::Result::kPassed) {
      const char* tag = c.result == JunitCase::Result::kFailed ? "failure" : "error";
      x += std::string("      <") + tag + " message=\"" + xml_escape(c.message) + "\" type=\"" +
           (c.result == JunitCase::Result::kFailed ? "expectation" : "run") + "\">" + xml_escape(c.details) + "</" +
           tag + ">\n";
    } else {
      x += "      <system-out>" + xml_escape(c.details) + "</system-out>\n";
    }
    x += "    </testcase>\n";
  }
  x += "  </testsuite>\n</testsuites>\n";
  return x;
}

}  // namespace ehpt::io
