// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// JUnit XML (the schema CI servers read: Jenkins, GitLab, GitHub's test reporters, Debian's
// python3-junitparser): one <testsuite> of <testcase>s, each passed, failed (<failure>) or in
// error (<error>), or skipped (<skipped>: it could not run here, and says why). A pure
// function of its input.

#include <string>
#include <vector>

namespace ehpt::io {

struct JunitCase {
  enum class Result { kPassed, kFailed, kError, kSkipped };
  std::string name;       // the test's name
  std::string classname;  // its group (the suite or folder)
  double time_s = 0.0;
  Result result = Result::kPassed;
  std::string message;    // one line: the first failed expectation, the error, or why it was skipped
  std::string details;    // the element's text: every expectation, the tail of a log
};

// The document (UTF-8, XML 1.0): characters XML 1.0 cannot carry (control characters other
// than tab and line breaks) are replaced by U+FFFD, so that any message stays well-formed.
std::string junit_xml(const std::string& suite, const std::vector<JunitCase>& cases);

// Text as XML character data or an attribute value (&, <, >, ", ' escaped).
std::string xml_escape(const std::string& text);

}  // namespace ehpt::io
