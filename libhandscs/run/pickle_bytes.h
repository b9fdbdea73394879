// torch::pickle_save (the bytes a checkpoint stores) made safe to run out of memory in: LibTorch's
// own lets std::bad_alloc escape its zip writer, whose destructor then throws ("unexpected pos") and
// std::terminate ends the process. Here a failed allocation ends in std::bad_alloc alone.
#pragma once

#include <ATen/core/ivalue.h>

#include <vector>

namespace handscs {

// The bytes torch::pickle_save(value) returns, byte for byte. Throws std::bad_alloc when memory
// runs out, never ends the process.
std::vector<char> pickle_bytes(const c10::IValue& value);

}  // namespace handscs
