// installed_script from a program of build/bin: the build folder's share/handscs/scripts/ beside
// bin/ holds the source tree's plot scripts (the install layout), and a script that is not there is
// an error naming the path tried.
#include <catch2/catch.hpp>

#include <filesystem>
#include <string>

#include "core/installed_paths.h"
#include "test_support.h"

TEST_CASE("installed paths: build/bin's programs find the source tree's scripts in ../share/handscs/scripts") {
  namespace fs = std::filesystem;
  CHECK(fs::equivalent(handscs::executable_dir(), handscs_test::kBin));
  const std::string expected = fs::path(handscs::executable_dir()).parent_path() / "share/handscs/scripts";
  for (const char* name : {"plot_sweep.py", "plot_features.py", "convert_mano.py", "convert_lpips_weights.py"}) {
    INFO(name);
    const std::string script = handscs::installed_script(name);
    CHECK(script == expected + "/" + name);
    CHECK(fs::equivalent(script, handscs_test::kSource + "/scripts/" + name));
  }
  CHECK(handscs_test::error_of([] { handscs::installed_script("no_such_script.py"); }) ==
        "no_such_script.py not found: tried " + expected + "/no_such_script.py (installed programs keep it in "
        "<prefix>/share/handscs/scripts/; a build folder links it there when configured)");
}
