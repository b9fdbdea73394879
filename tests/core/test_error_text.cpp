// What a program prints for the exception that ends it: LibTorch errors without their C++ stack
// trace (a user error printed a dozen frames of addresses), other errors as they are.
#include <c10/util/Exception.h>

#include <cstdlib>
#include <stdexcept>

#include "core/cli.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

namespace {
std::string text_of_torch_check() {
  try {
    TORCH_CHECK(false, "ssim: images must be at least 11x11, got 5x6");
  } catch (const std::exception& e) {
    return handscs::error_text(e);
  }
  return "";
}
}  // namespace

TEST_CASE("error_text: a TORCH_CHECK message without its stack trace") {
  unsetenv("HANDSCS_BACKTRACE");
  CHECK(text_of_torch_check() == "ssim: images must be at least 11x11, got 5x6");
  setenv("HANDSCS_BACKTRACE", "1", 1);
  CHECK(text_of_torch_check().find("Exception raised from") != std::string::npos);
  unsetenv("HANDSCS_BACKTRACE");
  CHECK(handscs::error_text(std::runtime_error("plain")) == "plain");
}
