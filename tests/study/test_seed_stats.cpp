// tools/study/seed_stats.py, the analysis scripts' mean and spread over seeds: its mean and sample std
// against the textbook formulas worked out here, no std for one value, nothing for none, a NaN or an
// infinity giving a NaN std instead of an error, and finite_mean_std leaving non-finite values and
// None out while counting what it kept.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "test_support.h"

namespace {

// Runs `expression` (Python, with seed_stats's names in scope) and returns what it prints.
std::string python_value(const std::string& expression) {
  const std::string dir = handscs_test::scratch_path("handscs_test_seed_stats", std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string out = dir + "/out.txt";
  const std::string command = "/usr/bin/python3 -c \"import sys; sys.path.insert(0, '" + handscs_test::kSource +
                              "/tools/study'); from seed_stats import *; import math; print(" + expression +
                              ")\" > '" + out + "' 2>&1";
  const int status = std::system(command.c_str());
  std::string text = handscs::read_file(out);
  std::filesystem::remove_all(dir);
  INFO(text);
  REQUIRE(status == 0);
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

// "(a, b)" or "(a, b, c)" as numbers (repr of floats; "None" and "nan" read as NaN).
std::vector<double> numbers(std::string text) {
  for (char& c : text)
    if (c == '(' || c == ')' || c == ',') c = ' ';
  std::istringstream in(text);
  std::vector<double> out;
  for (std::string word; in >> word;)
    out.push_back(word == "None" || word == "nan" ? std::nan("") : std::stod(word));
  return out;
}

}  // namespace

TEST_CASE("seed_stats.py: mean and sample std against the formulas; one value, none, non-finite values") {
  // 1, 2, 4: mean 7/3, sample variance ((4/3)^2 + (1/3)^2 + (5/3)^2) / 2 = 7/3.
  const auto three = numbers(python_value("mean_std([1, 2, 4])"));
  REQUIRE(three.size() == 2);
  CHECK(three[0] == Approx(7.0 / 3.0).epsilon(1e-14));
  CHECK(three[1] == Approx(std::sqrt(7.0 / 3.0)).epsilon(1e-14));
  // One seed: its value and no spread; no seeds: nothing.
  CHECK(python_value("mean_std([5.5])") == "(5.5, None)");
  CHECK(python_value("mean_std([])") == "(None, None)");
  // A NaN or an infinity: no error, a NaN std.
  CHECK(python_value("mean_std([float('nan'), 1.0])") == "(nan, nan)");
  CHECK(python_value("mean_std([float('inf'), 1.0])") == "(inf, nan)");
  // finite_mean_std keeps 1 and 3 of [1, None, nan, inf, 3]: mean 2, std sqrt 2, count 2.
  const auto kept = numbers(python_value("finite_mean_std([1, None, float('nan'), float('inf'), 3])"));
  REQUIRE(kept.size() == 3);
  CHECK(kept[0] == Approx(2.0).epsilon(1e-14));
  CHECK(kept[1] == Approx(std::sqrt(2.0)).epsilon(1e-14));
  CHECK(kept[2] == 2);
  CHECK(python_value("std_text(None, 3) + ' ' + std_text(0.12345, 3)") == "n/a 0.123");
}
