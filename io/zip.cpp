// SPDX-License-Identifier: BSD-3-Clause
#include "io/zip.hpp"

#include <array>
#include <set>

namespace ehpt::io {

namespace {

constexpr std::uint32_t kLocalSig = 0x04034b50, kCentralSig = 0x02014b50, kEndSig = 0x06054b50;
constexpr std::uint64_t kMax32 = 0xFFFFFFFFu;

std::array<std::uint32_t, 256> crc_table() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}

void put16(std::string& out, std::uint32_t v) {
  out.push_back(static_cast<char>(v & 0xFF));
  out.push_back(static_cast<char>((v >> 8) & 0xFF));
}
void put32(std::string& out, std::uint32_t v) {
  put16(out, v & 0xFFFF);
  put16(out, v >> 16);
}
std::uint32_t get16(std::string_view in, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(in[at])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(in[at + 1])) << 8;
}
std::uint32_t get32(std::string_view in, std::size_t at) { return get16(in, at) | get16(in, at + 2) << 16; }

// A name that stays inside the folder it is unpacked into.
bool safe_name(std::string_view name) {
  if (name.empty() || name.front() == '/' || name.find('\\') != std::string_view::npos ||
      name.find('\0') != std::string_view::npos) {
    return false;
  }
  std::size_t start = 0;
  while (start <= name.size()) {
    const std::size_t end = std::min(name.find('/', start), name.size());
    const std::string_view part = name.substr(start, end - start);
    if (part == ".." || part == "." || (part.empty() && end != name.size())) return false;
    start = end + 1;
  }
  return true;
}

// Every entry gets the same time stamp (1980-01-01 00:00, DOS time 0 / date 0x21): the archive
// is a function of its content alone, so the same FMU is the same bytes.
constexpr std::uint32_t kDosTime = 0, kDosDate = (0u << 9) | (1u << 5) | 1u;

}  // namespace

std::uint32_t crc32(std::string_view bytes) {
  static const std::array<std::uint32_t, 256> table = crc_table();
  std::uint32_t c = 0xFFFFFFFFu;
  for (const char ch : bytes) c = table[(c ^ static_cast<unsigned char>(ch)) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

bool zip_store(const std::vector<ZipEntry>& entries, std::string& archive, std::string& error) {
  archive.clear();
  if (entries.size() > 0xFFFF) {
    error = "zip: " + std::to_string(entries.size()) + " entries (at most 65535)";
    return false;
  }
  std::set<std::string> names;
  std::string central;
  for (const ZipEntry& e : entries) {
    if (!safe_name(e.name) || e.name.size() > 0xFFFF) {
      error = "zip: entry name '" + e.name + "' is not a relative path inside the archive";
      return false;
    }
    if (!names.insert(e.name).second) {
      error = "zip: entry '" + e.name + "' twice";
      return false;
    }
    if (e.data.size() > kMax32 || archive.size() > kMax32 - 30 - e.name.size() - e.data.size()) {
      error = "zip: '" + e.name + "' takes the archive past 4 GiB";
      return false;
    }
    const std::uint32_t crc = crc32(e.data), size = static_cast<std::uint32_t>(e.data.size());
    const std::uint32_t offset = static_cast<std::uint32_t>(archive.size());
    // local file header: version 2.0, no flags, stored
    put32(archive, kLocalSig);
    put16(archive, 20);
    put16(archive, 0);
    put16(archive, 0);
    put16(archive, kDosTime);
    put16(archive, kDosDate);
    put32(archive, crc);
    put32(archive, size);
    put32(archive, size);
    put16(archive, static_cast<std::uint32_t>(e.name.size()));
    put16(archive, 0);
    archive += e.name;
    archive += e.data;
    // its central directory record (made by: UNIX, 2.0; regular file, rw-r--r--)
    put32(central, kCentralSig);
    put16(central, (3u << 8) | 20u);
    put16(central, 20);
    put16(central, 0);
    put16(central, 0);
    put16(central, kDosTime);
    put16(central, kDosDate);
    put32(central, crc);
    put32(central, size);
    put32(central, size);
    put16(central, static_cast<std::uint32_t>(e.name.size()));
    put16(central, 0);
    put16(central, 0);
    put16(central, 0);
    put16(central, 0);
    put32(central, (0100644u) << 16);
    put32(central, offset);
    central += e.name;
  }
  if (archive.size() + central.size() > kMax32) {
    error = "zip: the archive passes 4 GiB";
    return false;
  }
  const std::uint32_t central_at = static_cast<std::uint32_t>(archive.size());
  archive += central;
  put32(archive, kEndSig);
  put16(archive, 0);
  put16(archive, 0);
  put16(archive, static_cast<std::uint32_t>(entries.size()));
  put16(archive, static_cast<std::uint32_t>(entries.size()));
  put32(archive, static_cast<std::uint32_t>(central.size()));
  put32(archive, central_at);
  put16(archive, 0);
  return true;
}

bool zip_read(std::string_view z, std::vector<ZipEntry>& entries, std::string& error) {
  entries.clear();
  // the end record: in the last 22 + 65535 bytes (a comment may follow it)
  if (z.size() < 22) {
    error = "not a zip archive (" + std::to_string(z.size()) + " bytes)";
    return false;
  }
  std::size_t end = std::string_view::npos;
  const std::size_t lowest = z.size() > 22 + 0xFFFF ? z.size() - 22 - 0xFFFF : 0;
  for (std::size_t at = z.size() - 22 + 1; at-- > lowest;) {
    if (get32(z, at) == kEndSig) {
      end = at;
      break;
    }
  }
  if (end == std::string_view::npos) {
    error = "not a zip archive (no end of central directory)";
    return false;
  }
  const std::size_t count = get16(z, end + 10), central_size = get32(z, end + 12), central_at = get32(z, end + 16);
  if (central_at > end || central_size > end - central_at) {
    error = "zip: the central directory lies outside the archive";
    return false;
  }
  std::size_t at = central_at;
  std::set<std::string> names;
  for (std::size_t i = 0; i < count; ++i) {
    if (at + 46 > end || get32(z, at) != kCentralSig) {
      error = "zip: central directory record " + std::to_string(i) + " is damaged";
      return false;
    }
    const std::uint32_t method = get16(z, at + 10), crc = get32(z, at + 16), packed = get32(z, at + 20),
                        size = get32(z, at + 24), name_len = get16(z, at + 28), extra = get16(z, at + 30),
                        comment = get16(z, at + 32), local = get32(z, at + 42);
    if (at + 46 + name_len > end) {
      error = "zip: central directory record " + std::to_string(i) + " is damaged";
      return false;
    }
    ZipEntry e;
    e.name = std::string(z.substr(at + 46, name_len));
    at += 46 + name_len + extra + comment;
    if (!e.name.empty() && e.name.back() == '/') continue;  // a folder
    if (!safe_name(e.name) || !names.insert(e.name).second) {
      error = "zip: entry '" + e.name + "' would leave the folder it is unpacked into, or repeats";
      return false;
    }
    if (method != 0 || packed != size) {
      error = "zip: entry '" + e.name + "' is compressed (method " + std::to_string(method) +
              "); this reader takes stored entries, as ehpt fmu writes them";
      return false;
    }
    if (local + 30 > central_at || get32(z, local) != kLocalSig) {
      error = "zip: entry '" + e.name + "': its local header is damaged";
      return false;
    }
    const std::size_t data_at = local + 30 + get16(z, local + 26) + get16(z, local + 28);
    if (data_at > central_at || size > central_at - data_at) {
      error = "zip: entry '" + e.name + "' lies outside the archive";
      return false;
    }
    e.data = std::string(z.substr(data_at, size));
    if (crc32(e.data) != crc) {
      error = "zip: entry '" + e.name + "': CRC does not match (the archive is damaged)";
      return false;
    }
    entries.push_back(std::move(e));
  }
  return true;
}

}  // namespace ehpt::io
