#include "core/threads.h"

#include <sched.h>

#include <fstream>
#include <string>

#include <ATen/Parallel.h>
#include <omp.h>
#include <torch/types.h>

namespace handscs {

int available_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) {
    const int count = CPU_COUNT(&set);
    if (count > 0) return count;
  }
  return 1;
}

int set_threads(int threads) {
  const int count = threads > 0 ? threads : available_cores();
  omp_set_num_threads(count);
  at::set_num_threads(count);
  // Inter-op parallelism is unused (no parallel graph execution); one thread avoids a second pool.
  static bool interop_set = false;
  if (!interop_set) {
    at::set_num_interop_threads(1);
    interop_set = true;
  }
  return count;
}

SingleThreadScope::SingleThreadScope() : saved_(at::get_num_threads()) { set_threads(1); }
SingleThreadScope::~SingleThreadScope() { set_threads(saved_); }

std::string blas_in_use() {
  // Make sure the BLAS library is loaded and initialised before looking.
  auto a = torch::ones({8, 8});
  (void)torch::mm(a, a);
  std::ifstream maps("/proc/self/maps");
  std::string line;
  std::string found;
  while (std::getline(maps, line)) {
    const size_t slash = line.rfind('/');
    if (slash == std::string::npos) continue;
    const std::string name = line.substr(slash + 1);
    if (name.find("openblas") != std::string::npos) return name;
    if (name.find("libmkl") != std::string::npos) return name;
    if (name.find("libblis") != std::string::npos) return name;
    if (name.rfind("libblas.so", 0) == 0) found = name;
  }
  if (!found.empty()) return found + " (reference BLAS: slow; install libopenblas0-openmp)";
  return "unknown";
}

bool has_native_bf16_matmul() {
  return __builtin_cpu_supports("avx512bf16") && at::hasMKLDNN();
}

}  // namespace handscs
