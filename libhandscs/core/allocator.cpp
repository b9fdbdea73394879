#include "core/allocator.h"

#include <malloc.h>
#include <spdlog/spdlog.h>

namespace handscs {

void keep_freed_memory_for_reuse() {
  constexpr int kMmapThreshold = 32 << 20;  // glibc's maximum on 64-bit (4 * 1024 * 1024 * sizeof(long))
  constexpr int kTrimThreshold = 1 << 30;   // free heap kept below this
  if (mallopt(M_MMAP_THRESHOLD, kMmapThreshold) != 1 || mallopt(M_TRIM_THRESHOLD, kTrimThreshold) != 1)
    spdlog::debug("mallopt refused the allocator settings; glibc's defaults stay");
}

}  // namespace handscs
