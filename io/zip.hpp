// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// ZIP archives as an FMU is one (FMI: "a zip file"), stored without compression: the writer
// (ehpt fmu) and a reader for the archives it writes (the project's FMU importer, tests). Pure
// functions over bytes; the file I/O is the caller's. The format: PKWARE's APPNOTE (local file
// headers, the central directory, the end-of-central-directory record), no ZIP64: an archive
// and each entry below 4 GiB, at most 65 535 entries, checked.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ehpt::io {

struct ZipEntry {
  std::string name;  // the path inside the archive, '/' separated, no leading '/', no ".."
  std::string data;  // the bytes
};

// CRC-32 (ISO-HDLC, as ZIP uses it).
std::uint32_t crc32(std::string_view bytes);

// The archive; false and why if an entry's name is not a safe relative path, a name repeats, or
// a size passes ZIP's 32-bit fields.
bool zip_store(const std::vector<ZipEntry>& entries, std::string& archive, std::string& error);

// The entries of an archive zip_store wrote (stored entries; another method is an error, as is
// a name that would leave the folder it is unpacked into, or a CRC that does not match).
bool zip_read(std::string_view archive, std::vector<ZipEntry>& entries, std::string& error);

}  // namespace ehpt::io
