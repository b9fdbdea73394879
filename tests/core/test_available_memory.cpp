// core/available_memory.h: MemAvailable read from /proc/meminfo's text, and its absence reported.
#include <catch2/catch.hpp>

#include "core/available_memory.h"

using handscs::mem_available_bytes;

TEST_CASE("available memory: MemAvailable is read in bytes, its absence is -1") {
  const std::string meminfo =
      "MemTotal:       24683748 kB\nMemFree:         1022420 kB\nMemAvailable:   23457780 kB\n";
  CHECK(mem_available_bytes(meminfo) == int64_t{23457780} * 1024);
  CHECK(mem_available_bytes("MemAvailable: 4 kB\n") == 4096);  // on the first line
  // Kernels before 3.14 have no such line; a damaged one has no number.
  CHECK(mem_available_bytes("MemTotal:       24683748 kB\nMemFree:         1022420 kB\n") == -1);
  CHECK(mem_available_bytes("MemAvailable:   lots\n") == -1);
  CHECK(mem_available_bytes("XMemAvailable:   5 kB\n") == -1);  // only a line's own key
  // This machine's: Linux has /proc/meminfo, and some memory is always available.
  CHECK(handscs::available_memory_bytes() > 0);
}
