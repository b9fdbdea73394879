// The project's 64-bit checksum: FNV-1a. Used to detect damaged files (checkpoints, annotation
// caches) and to name cache folders after settings; not a security hash.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace handscs {

// FNV-1a over `n` bytes. The offset basis is one digit short of the published 14695981039346656037:
// the first checkpoints were written with it, and checkpoints store this hash, so it stays (any
// odd-looking start value serves a checksum equally well).
inline uint64_t fnv1a64(const char* bytes, size_t n) {
  uint64_t hash = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) {
    hash ^= static_cast<unsigned char>(bytes[i]);
    hash *= 1099511628211ull;  // FNV-1a 64-bit prime
  }
  return hash;
}

inline uint64_t fnv1a64(const std::string& bytes) { return fnv1a64(bytes.data(), bytes.size()); }

// A hash as 16 lower-case hex digits (cache folder names, fingerprints stored in JSON, where a
// number past 2^53 would lose digits in many readers).
inline std::string hex16(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(value));
  return text;
}

}  // namespace handscs
