#include "core/available_memory.h"

#include <cstdlib>
#include <exception>

#include "core/atomic_file.h"

namespace handscs {

int64_t mem_available_bytes(const std::string& meminfo_text) {
  // The key at the start of a line (the text's first line included).
  const std::string text = "\n" + meminfo_text, key = "\nMemAvailable:";
  const size_t at = text.find(key);
  if (at == std::string::npos) return -1;
  const char* number = text.c_str() + at + key.size();
  char* end = nullptr;
  const long long kib = std::strtoll(number, &end, 10);
  if (end == number || kib < 0) return -1;
  return static_cast<int64_t>(kib) * 1024;  // the kernel's "kB" are KiB
}

int64_t available_memory_bytes() {
  try {
    // /proc/meminfo is about 1.5 KB; its size is not reported, so the bound caps the read.
    return mem_available_bytes(read_file("/proc/meminfo", 1 << 20));
  } catch (const std::exception&) {
    return -1;
  }
}

}  // namespace handscs
