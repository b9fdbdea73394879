#include "run/pickle_bytes.h"

#include <caffe2/serialize/inline_container.h>
#include <torch/csrc/jit/serialization/export.h>
#include <torch/csrc/jit/serialization/pickler.h>

#include <new>

namespace handscs {

std::vector<char> pickle_bytes(const c10::IValue& value) {
  // As torch::jit::pickle_save (LibTorch 1.13): the pickle, then a zip archive of it and the tensors.
  std::vector<char> pickled;
  torch::jit::Pickler pickler(
      [&](const char* bytes, size_t size) { pickled.insert(pickled.end(), bytes, bytes + size); });
  pickler.protocol();
  pickler.pushIValue(value);
  pickler.stop();
  // The archive's writer never throws: a failed append is remembered and the rest passed over, so
  // the zip writer stays consistent and finishes.
  std::vector<char> archive;
  bool out_of_memory = false;
  const auto append = [&](const void* data, size_t size) -> size_t {
    if (out_of_memory) return size;
    try {
      const char* bytes = static_cast<const char*>(data);
      archive.insert(archive.end(), bytes, bytes + size);
    } catch (const std::bad_alloc&) {
      out_of_memory = true;
      std::vector<char>().swap(archive);
    }
    return size;
  };
  // On the heap: when the zip writer fails itself (its own allocations), its destructor would
  // finish the broken archive, throw from a destructor and end the process; it is left undestroyed
  // then (a small leak on a path that ends in an error).
  auto* writer = new caffe2::serialize::PyTorchStreamWriter(append);
  try {
    torch::jit::writeArchiveAndTensors("data", pickled.data(), pickled.size(), pickler.tensorData(), *writer);
    writer->writeEndOfFile();
  } catch (...) {
    throw std::bad_alloc();
  }
  delete writer;
  if (out_of_memory) throw std::bad_alloc();
  return archive;
}

}  // namespace handscs
