// SPDX-License-Identifier: BSD-3-Clause
// main() for the fuzz harnesses when the compiler has no libFuzzer (the g++ build CI uses), so
// that every build runs them as a ctest smoke test. It runs LLVMFuzzerTestOneInput over every
// file of the corpus folders given, then over N mutations of them made by a fixed-seed xorshift
// mutator: the same command gives the same inputs, so a failure reproduces. There is no coverage
// feedback: this finds shallow bugs and keeps the harnesses compiling and running; tools/fuzz.sh
// does the real fuzzing with clang.
//
// usage: HARNESS [--iterations N] [--seed S] [--timeout SECONDS] PATH...
//   PATH           a corpus folder (its files, sorted by name) or one input file
//   --iterations   mutated inputs after the corpus; default 3000, or 0 when only files are
//                  given (running a saved crash input just reruns it)
//   --seed         mutator seed (default 1)
//   --timeout      seconds one input may take before it counts as a hang (default 10, 0: none)
// On a crash, an uncaught exception or a hang, the input is saved to
// ./standalone-crash-PID in the working folder and the process dies with the signal.

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

// ---- saving the input that killed us ---------------------------------------------------------
// Signal handlers may only use async-signal-safe calls: the path is formatted up front and the
// input is reached through plain globals.

char g_crash_path[64];
const char* g_argv0 = "HARNESS";
const std::uint8_t* volatile g_input_data = nullptr;
volatile std::size_t g_input_size = 0;

void write_stderr(const char* text) {
  const ssize_t ignored = ::write(STDERR_FILENO, text, std::strlen(text));
  (void)ignored;
}

void save_current_input() {
  const int fd = ::open(g_crash_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) return;
  const std::uint8_t* data = g_input_data;
  std::size_t left = g_input_size;
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n <= 0) break;
    data += n;
    left -= static_cast<std::size_t>(n);
  }
  ::close(fd);
  write_stderr("standalone_main: the input is saved as ");
  write_stderr(g_crash_path);
  write_stderr("; rerun it with: ");
  write_stderr(g_argv0);
  write_stderr(" ");
  write_stderr(g_crash_path);
  write_stderr("\n");
}

const char* signal_name(int sig) {
  switch (sig) {
    case SIGSEGV: return "SIGSEGV (bad memory access or stack overflow)";
    case SIGBUS: return "SIGBUS";
    case SIGILL: return "SIGILL";
    case SIGFPE: return "SIGFPE";
    case SIGABRT: return "SIGABRT (abort: a broken contract, an assertion or an uncaught exception)";
    default: return "a fatal signal";
  }
}

extern "C" void on_fatal_signal(int sig) {
  if (sig == SIGALRM) {
    write_stderr("standalone_main: timeout: one input ran longer than --timeout\n");
  } else {
    write_stderr("standalone_main: ");
    write_stderr(signal_name(sig));
    write_stderr(" while running an input\n");
  }
  save_current_input();
  if (sig == SIGALRM) {
    std::signal(SIGABRT, SIG_DFL);
    std::abort();
  }
  // SA_RESETHAND restored the default action: dying by the same signal keeps the exit status honest
  std::raise(sig);
}

void install_handlers() {
  std::snprintf(g_crash_path, sizeof g_crash_path, "standalone-crash-%ld", static_cast<long>(::getpid()));
  // a stack overflow (deep recursion in a parser) needs a stack of its own to report from
  static char alt_stack[1 << 16];
  stack_t ss{};
  ss.ss_sp = alt_stack;
  ss.ss_size = sizeof alt_stack;
  ::sigaltstack(&ss, nullptr);
  struct sigaction sa{};
  sa.sa_handler = on_fatal_signal;
  sa.sa_flags = SA_ONSTACK | SA_RESETHAND;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGALRM}) ::sigaction(sig, &sa, nullptr);
  // an escaping exception is a finding: name it before abort() saves the input
  std::set_terminate([] {
    if (std::exception_ptr e = std::current_exception()) {
      try {
        std::rethrow_exception(e);
      } catch (const std::exception& x) {
        std::fprintf(stderr, "standalone_main: uncaught exception: %s\n", x.what());
      } catch (...) {
        std::fprintf(stderr, "standalone_main: uncaught exception of a non-std type\n");
      }
    }
    std::abort();
  });
}

// ---- the mutator ------------------------------------------------------------------------------

// Tokens that tend to break number parsers, CSV splitting and TOML: special and extreme
// numbers, quotes and brackets, line ends, a UTF-8 byte order mark, a NUL, and a few words of
// the formats themselves so that mutations stay near meaningful input.
const std::string_view kTokens[] = {
    "nan", "-nan", "inf", "-inf", "+inf", "1e308", "1e309", "-1e308", "4.9e-324", "1e-320", "-0", "-0.0", "0",
    "-1", "1.5", "9223372036854775807", "-9223372036854775808", "18446744073709551616", "0x7f", "1_000", "1.",
    ".5", "\"", "'", "\"\"\"", "'''", "[", "]", "[[", "]]", "{", "}", "=", ",", ".", "#", "\\", "\\u0000",
    "\n", "\r\n", "\r", "\t", " ", "\xEF\xBB\xBF", std::string_view("\0", 1), "\xFF\xFE", "\xC3\x28",
    "true", "false", "1979-05-27T07:32:00Z", "07:32:00", "=\"\"", "[vehicle]", "[solver]", "[output]",
    "[drive]", "[ecu]", "[ice]", "kind = \"bev\"", "kind = \"psd\"", "kind = \"drive_rig\"", "vehicle.",
    "solver.", "output.", "solver.step_s=", "solver.duration_s=", "output.decimation=", "output.interval_s=",
    "time_s", "speed_kmh", "speed_m_s", ",,", "a.b.c", "x = { a = 1 }", "[1, 2, 3]", "[[1], [\"a\"]]",
};

class Mutator {
 public:
  Mutator(std::uint64_t seed, const std::vector<Bytes>& corpus) : state_(seed == 0 ? 1 : seed), corpus_(corpus) {}

  Bytes next() {
    Bytes b = corpus_.empty() ? Bytes{} : corpus_[below(corpus_.size())];
    const std::size_t rounds = 1 + below(4);
    for (std::size_t i = 0; i < rounds; ++i) mutate_once(b);
    if (b.size() > kMaxSize) b.resize(kMaxSize);
    return b;
  }

 private:
  static constexpr std::size_t kMaxSize = 1 << 18;

  std::uint64_t next_u64() {
    // xorshift64 (Marsaglia): tiny, fast, the same sequence on every platform
    state_ ^= state_ << 13;
    state_ ^= state_ >> 7;
    state_ ^= state_ << 17;
    return state_;
  }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(next_u64() % n); }
  std::size_t position(const Bytes& b) { return below(b.size() + 1); }
  std::string_view token() { return kTokens[below(std::size(kTokens))]; }
  void insert(Bytes& b, std::size_t at, std::string_view text) {
    b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), text.begin(), text.end());
  }
  // [begin, end) of the line around a random byte, its '\n' included
  std::pair<std::size_t, std::size_t> random_line(const Bytes& b) {
    const std::size_t at = below(b.size());
    std::size_t begin = at, end = at;
    while (begin > 0 && b[begin - 1] != '\n') --begin;
    while (end < b.size() && b[end] != '\n') ++end;
    return {begin, std::min(end + 1, b.size())};
  }

  void mutate_once(Bytes& b) {
    switch (below(11)) {
      case 0:  // flip one bit
        if (!b.empty()) b[below(b.size())] ^= static_cast<std::uint8_t>(1u << below(8));
        break;
      case 1: {  // overwrite a byte with a structural one
        static constexpr char kRaw[] = "\0\xFF\n\r\t ,\"'#=[]{}.-+eE0129\\";
        static constexpr std::string_view kBytes(kRaw, sizeof kRaw - 1);
        if (!b.empty()) b[below(b.size())] = static_cast<std::uint8_t>(kBytes[below(kBytes.size())]);
        break;
      }
      case 2: {  // insert random bytes
        const std::size_t at = position(b), n = 1 + below(8);
        for (std::size_t i = 0; i < n; ++i) {
          b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<std::uint8_t>(next_u64()));
        }
        break;
      }
      case 3: {  // delete a range
        if (b.empty()) break;
        const std::size_t at = below(b.size()), n = std::min(b.size() - at, 1 + below(16));
        b.erase(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n));
        break;
      }
      case 4:  // insert a token
        insert(b, position(b), token());
        break;
      case 5: {  // replace a few bytes (often a number or a word) by a token
        const std::size_t at = position(b), n = std::min(b.size() - at, below(8));
        b.erase(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n));
        insert(b, at, token());
        break;
      }
      case 6: {  // splice: the head of this input, the tail of another corpus entry
        if (corpus_.empty()) break;
        const Bytes& other = corpus_[below(corpus_.size())];
        const std::size_t cut = position(b), from = position(other);
        b.resize(cut);
        b.insert(b.end(), other.begin() + static_cast<std::ptrdiff_t>(from), other.end());
        break;
      }
      case 7: {  // copy a chunk elsewhere
        if (b.empty()) break;
        const std::size_t from = below(b.size()), n = std::min(b.size() - from, 1 + below(64));
        const Bytes chunk(b.begin() + static_cast<std::ptrdiff_t>(from),
                          b.begin() + static_cast<std::ptrdiff_t>(from + n));
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(position(b)), chunk.begin(), chunk.end());
        break;
      }
      case 8: {  // a very long line: one byte or one token repeated thousands of times
        const std::string_view piece = below(2) == 0 ? std::string_view("9,aA \"[", 7).substr(below(7), 1) : token();
        const std::size_t repeat = (1000 + below(64000)) / std::max<std::size_t>(1, piece.size());
        std::string run;
        run.reserve(repeat * piece.size());
        for (std::size_t i = 0; i < repeat; ++i) run += piece;
        insert(b, position(b), run);
        break;
      }
      case 9: {  // duplicate, delete or move a whole line (rows of a CSV, keys of a TOML)
        if (b.empty()) break;
        const auto [begin, end] = random_line(b);
        const Bytes line(b.begin() + static_cast<std::ptrdiff_t>(begin), b.begin() + static_cast<std::ptrdiff_t>(end));
        const std::size_t op = below(3);
        if (op != 0) b.erase(b.begin() + static_cast<std::ptrdiff_t>(begin), b.begin() + static_cast<std::ptrdiff_t>(end));
        if (op != 1) b.insert(b.begin() + static_cast<std::ptrdiff_t>(position(b)), line.begin(), line.end());
        break;
      }
      default:  // cut the end off
        b.resize(position(b));
        break;
    }
  }

  std::uint64_t state_;
  const std::vector<Bytes>& corpus_;
};

// ---- main -------------------------------------------------------------------------------------

Bytes read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void run_one(const Bytes& input, unsigned timeout_s) {
  g_input_data = input.data();
  g_input_size = input.size();
  if (timeout_s > 0) ::alarm(timeout_s);
  LLVMFuzzerTestOneInput(input.data(), input.size());
  if (timeout_s > 0) ::alarm(0);
}

int usage(const char* argv0, const char* problem) {
  std::fprintf(stderr, "%s: %s\nusage: %s [--iterations N] [--seed S] [--timeout SECONDS] CORPUS_DIR_OR_FILE...\n",
               argv0, problem, argv0);
  return 2;
}

bool parse_count(const char* text, unsigned long long& out) {
  char* end = nullptr;
  out = std::strtoull(text, &end, 10);
  return end != text && *end == '\0' && text[0] != '-';
}

}  // namespace

int main(int argc, char** argv) {
  unsigned long long iterations = 3000, seed = 1, timeout_s = 10;
  bool iterations_given = false, folder_given = false;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const auto number_option = [&](std::string_view name, unsigned long long& out) {
      if (arg != name) return false;
      if (i + 1 >= argc || !parse_count(argv[i + 1], out)) {
        std::exit(usage(argv[0], (std::string(name) + " needs a whole number").c_str()));
      }
      ++i;
      return true;
    };
    if (number_option("--iterations", iterations)) {
      iterations_given = true;
      continue;
    }
    if (number_option("--seed", seed) || number_option("--timeout", timeout_s)) continue;
    if (arg.rfind("-", 0) == 0) {
      return usage(argv[0], ("unknown option " + std::string(arg)).c_str());
    } else if (fs::is_directory(argv[i])) {
      folder_given = true;
      std::vector<fs::path> in_folder;
      for (const auto& e : fs::directory_iterator(argv[i])) {
        if (e.is_regular_file()) in_folder.push_back(e.path());
      }
      // directory order differs between file systems: sorted, a run is the same everywhere
      std::sort(in_folder.begin(), in_folder.end());
      files.insert(files.end(), in_folder.begin(), in_folder.end());
    } else if (fs::is_regular_file(argv[i])) {
      files.emplace_back(argv[i]);
    } else {
      // a mistyped corpus path must fail the smoke test, not make it pass on nothing
      return usage(argv[0], ("no such file or folder: " + std::string(arg)).c_str());
    }
  }
  if (files.empty()) return usage(argv[0], "no input files (give a corpus folder)");
  if (!iterations_given && !folder_given) iterations = 0;

  g_argv0 = argv[0];
  install_handlers();
  const auto start = std::chrono::steady_clock::now();
  std::vector<Bytes> corpus;
  for (const fs::path& f : files) corpus.push_back(read_file(f));
  std::size_t largest = 0;
  for (const Bytes& input : corpus) {
    run_one(input, static_cast<unsigned>(timeout_s));
    largest = std::max(largest, input.size());
  }
  Mutator mutator(seed, corpus);
  for (unsigned long long i = 0; i < iterations; ++i) {
    const Bytes input = mutator.next();
    run_one(input, static_cast<unsigned>(timeout_s));
    largest = std::max(largest, input.size());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("standalone_main: ran %llu inputs (%zu corpus files + %llu mutations, seed %llu) in %.2f s, "
              "largest %zu bytes; no crash, hang or exception\n",
              static_cast<unsigned long long>(corpus.size()) + iterations, corpus.size(), iterations, seed, seconds,
              largest);
  return 0;
}
