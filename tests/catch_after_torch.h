// Catch2 for a test that includes LibTorch headers first: c10 pulls in glog, whose CHECK macro would
// replace Catch2's, so glog's is dropped before Catch2 comes in. Include it after the LibTorch
// headers (catch_torch.h does both).
#pragma once

#include <string>
#include <vector>

#include <c10/util/Logging.h>  // glog's CHECK and stl_logging.h, whatever came before

#undef CHECK
#include <catch2/catch.hpp>

// glog's stl_logging.h declares operator<< for every std::vector, so Catch2 would print vectors
// through it, which does not compile for elements without an operator<< (std::array): print them
// as Catch2 prints other ranges.
namespace Catch {
template <typename T, typename Allocator>
struct StringMaker<std::vector<T, Allocator>> {
  static std::string convert(const std::vector<T, Allocator>& v) { return ::Catch::rangeToString(v); }
};
}  // namespace Catch
