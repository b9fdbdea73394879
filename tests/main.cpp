// Catch2 v2 main, compiled once and shared by every test executable. Each test process writes its
// scratch files (captures, runs, logs) under a folder of its own, set as TMPDIR for itself and the
// programs it starts, and removed when every test passed: thousands of test runs otherwise fill the
// temp folder with gigabytes of captures. After a failure the folder is kept and named, for a look.
// HANDSCS_KEEP_TEST_FILES=1 keeps it always.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // mkdtemp: a folder of its own even where a failed run kept one under the same process id.
  std::string scratch = (fs::temp_directory_path(ec) / ("handscs_test_" + std::to_string(::getpid()) + "_XXXXXX")).string();
  const bool own_folder = !ec && ::mkdtemp(scratch.data()) != nullptr;
  if (own_folder) ::setenv("TMPDIR", scratch.c_str(), 1);
  const int result = Catch::Session().run(argc, argv);
  if (own_folder) {
    const char* keep = std::getenv("HANDSCS_KEEP_TEST_FILES");
    if (result == 0 && !(keep && std::string(keep) == "1"))
      fs::remove_all(scratch, ec);  // a child still writing can make this fail: left, harmlessly
    else
      std::fprintf(stderr, "test files kept in %s\n", scratch.c_str());
  }
  return result;
}
