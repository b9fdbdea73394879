// How the C allocator treats freed memory. Every image the tools score and every training step
// allocates and frees the same large tensors (LPIPS feature maps, SSIM planes, rasterizer buffers:
// 0.1-30 MB each). glibc's defaults hand such blocks back to the kernel on free (mmap'ed blocks,
// heap trimming), so the next image faults every page in again and clears it. Freed blocks are
// kept for reuse instead (docs/BENCHMARKS.md#evaluation).
#pragma once

namespace handscs {

// Serves blocks up to 32 MiB (glibc's largest allowed mmap threshold on 64-bit) from the heap and
// returns free heap memory to the kernel only beyond 1 GiB. Peak memory is unchanged; memory freed
// after the peak stays with the process. Called by start_up() and by the benchmarks.
void keep_freed_memory_for_reuse();

}  // namespace handscs
