// shell_quote against /bin/sh itself: each quoted word, echoed by the shell, comes back unchanged.
#include <catch2/catch.hpp>

#include <cstdio>
#include <string>

#include "core/cli.h"

namespace {
std::string echo_through_shell(const std::string& word) {
  FILE* pipe = popen(("printf '%s' " + word).c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::string out;
  char buffer[256];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) out.append(buffer, n);
  pclose(pipe);
  return out;
}
}  // namespace

TEST_CASE("shell_quote: words survive the shell, plain words stay unquoted") {
  CHECK(handscs::shell_quote("runs/demo_1.json") == "runs/demo_1.json");
  CHECK(handscs::shell_quote("my runs/a b") == "'my runs/a b'");
  for (const std::string word : {"my runs/a b", "it's", "$HOME `x` \"q\"", "a;b|c&d", "", "*?[]"}) {
    INFO(word);
    CHECK(echo_through_shell(handscs::shell_quote(word)) == word);
  }
}
