#include "train/out_of_memory.h"

#include <c10/util/Exception.h>
#include <opencv2/core.hpp>

#include <cstdlib>
#include <new>

#include "core/text.h"

namespace handscs {

namespace {

// LibTorch's CPU allocator (c10/core/impl/alloc_cpu.cpp) says "DefaultCPUAllocator: not enough
// memory: you tried to allocate N bytes" or "... can't allocate memory: ..." from its enforce in
// alloc_cpu.
bool names_failed_allocation(const std::string& what) {
  for (const char* words : {"alloc_cpu", "DefaultCPUAllocator", "can't allocate memory"})
    if (what.find(words) != std::string::npos) return true;
  return false;
}

}  // namespace

bool is_out_of_memory(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e)) return true;
  // OpenCV's allocations (cv::Mat) fail with cv::Error::StsNoMem.
  if (const auto* cv_error = dynamic_cast<const cv::Exception*>(&e)) return cv_error->code == cv::Error::StsNoMem;
  const auto* torch_error = dynamic_cast<const c10::Error*>(&e);
  return torch_error && names_failed_allocation(torch_error->what_without_backtrace());
}

Error out_of_memory_error(const std::exception& e, const std::string& when, int64_t gaussians,
                          const std::string& last_checkpoint) {
  std::string text = "out of memory " + when;
  if (gaussians >= 0) text += " with " + std::to_string(gaussians) + " Gaussians";
  // The request's size is what a user can compare with the machine's memory.
  const std::string marker = "you tried to allocate ";
  const auto* torch_error = dynamic_cast<const c10::Error*>(&e);
  const std::string what = torch_error ? torch_error->what_without_backtrace() : "";
  if (const size_t at = what.find(marker); at != std::string::npos)
    text += " (a request of " + bytes_text(std::atof(what.c_str() + at + marker.size())) + " failed)";
  text += ": the machine cannot hold this run. Fewer Gaussians (a lower train.densify.max_gaussians, "
          "a higher train.densify.grad_threshold or train.densify.interval, an earlier "
          "train.densify.stop), smaller decoders (model.decoder_hidden) or smaller images "
          "(train.resolution_scale) need less";
  if (gaussians >= 0)
    text += last_checkpoint.empty() ? "; no checkpoint was written before it"
                                    : "; the last checkpoint, " + last_checkpoint + ", is kept";
  return Error(text);
}

}  // namespace handscs
