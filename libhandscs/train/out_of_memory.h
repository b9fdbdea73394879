// A run that ran out of memory, named: std::bad_alloc and LibTorch's failed CPU allocations
// ("[enforce fail at alloc_cpu.cpp:75] ... you tried to allocate N bytes") become an Error saying
// when memory ran out, how many Gaussians the run had then, and the keys that make it need less.
#pragma once

#include <cstdint>
#include <exception>
#include <string>

#include "core/error.h"

namespace handscs {

// True for std::bad_alloc and LibTorch's CPU allocator's failures; false for anything else.
bool is_out_of_memory(const std::exception& e);

// The Error for an out-of-memory failure `e`: `when` it happened ("at step 12", "while validating
// after step 500"), the Gaussian count then (< 0: not known, as before the model exists), the
// failed request's size when LibTorch names it, and the keys that lower what a run needs. With a
// count, the message also names `last_checkpoint`, the file a resume continues from ("": none yet).
Error out_of_memory_error(const std::exception& e, const std::string& when, int64_t gaussians,
                          const std::string& last_checkpoint = "");

}  // namespace handscs
