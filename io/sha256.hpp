// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// SHA-256 (FIPS 180-4), so that ehpt can name the exact input files of a run (cycles, maps,
// vehicles) by their digest, as `sha256sum` does, without a crypto library. Not for secrets:
// no constant-time care is taken, none is needed for checksums of our own files.

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace ehpt::io {

// Streaming digest: update() any number of times with pieces of any size, then finish().
// No heap: the state is 8 words, a 64-byte block buffer and a 64-bit length.
class Sha256 {
 public:
  Sha256() { reset(); }
  void update(std::string_view bytes);
  // The digest of everything given to update() since construction or the last finish();
  // the object is then reset for reuse.
  std::array<std::uint8_t, 32> finish();

 private:
  void reset();
  void compress(const std::uint8_t* block);  // one 64-byte block into h_

  std::array<std::uint32_t, 8> h_{};
  std::array<std::uint8_t, 64> block_{};
  std::size_t block_used_ = 0;     // bytes waiting in block_ (0..63)
  std::uint64_t length_bytes_ = 0;  // the message length; FIPS wants it in bits mod 2^64
};

// 64 lowercase hex digits, as sha256sum prints them.
std::string to_hex(const std::array<std::uint8_t, 32>& digest);
std::string sha256_hex(std::string_view bytes);

}  // namespace ehpt::io
