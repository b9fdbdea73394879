// Thread pool set-up: one call sets LibTorch's intra-op pool and OpenMP's pool to the same count
// (they share libgomp), and reports which BLAS library the process actually loaded.
#pragma once

#include <string>

namespace handscs {

// Number of cores this process may run on (sched affinity), at least 1.
int available_cores();

// Sets LibTorch and OpenMP to `threads` threads (0 = all available cores); returns the count set.
int set_threads(int threads);

// Runs LibTorch and OpenMP on one thread for its lifetime, then restores the previous count: for
// results that must not depend on the thread count (LibTorch splits its reductions by it).
class SingleThreadScope {
 public:
  SingleThreadScope();
  ~SingleThreadScope();
  SingleThreadScope(const SingleThreadScope&) = delete;
  SingleThreadScope& operator=(const SingleThreadScope&) = delete;

 private:
  int saved_;
};

// Name of the BLAS shared library mapped into this process (e.g. "libopenblasp-r0.3.21.so" or
// "libblas.so.3 (reference BLAS: slow)"), found from /proc/self/maps after a small matmul.
std::string blas_in_use();

// True when bfloat16 matmuls run natively here: the CPU has AVX512-BF16 and LibTorch was built
// with oneDNN, which then multiplies bf16 with float accumulation (measured 2.7x float's speed).
bool has_native_bf16_matmul();

}  // namespace handscs
