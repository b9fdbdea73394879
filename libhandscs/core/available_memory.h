// The memory this machine can still give a process, as the kernel estimates it: MemAvailable of
// /proc/meminfo (free memory plus the caches it can drop, without swapping).
#pragma once

#include <cstdint>
#include <string>

namespace handscs {

// MemAvailable in bytes from the text of /proc/meminfo ("MemAvailable:   23457780 kB"); -1 when the
// text has no such line (kernels before 3.14).
int64_t mem_available_bytes(const std::string& meminfo_text);

// MemAvailable of this machine in bytes; -1 when it cannot be read (no /proc/meminfo).
int64_t available_memory_bytes();

}  // namespace handscs
