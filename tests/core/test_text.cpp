// core/text.h: lists and numbers as messages print them.
#include <catch2/catch.hpp>

#include "core/text.h"

using handscs::list_text;
using handscs::number_text;

TEST_CASE("text: lists are joined, long ones cut after max_items with the total") {
  CHECK(list_text({}) == "");
  CHECK(list_text({"0"}) == "0");
  CHECK(list_text({"a", "b", "c"}) == "a, b, c");
  CHECK(list_text({"a", "b", "c"}, 3) == "a, b, c");
  CHECK(list_text({"a", "b", "c", "d"}, 2) == "a, b, ... (4 in all)");
}

TEST_CASE("text: numbers in the form a user types them") {
  CHECK(number_text(1e30) == "1e+30");
  CHECK(number_text(0.066) == "0.066");
  CHECK(number_text(30) == "30");
}

TEST_CASE("text: shapes print as messages show them") {
  CHECK(handscs::shape_text(std::vector<int64_t>{}) == "[]");
  CHECK(handscs::shape_text(std::vector<int64_t>{778, 3, 10}) == "[778, 3, 10]");
  CHECK(handscs::shape_text({23340}) == "[23340]");
}

TEST_CASE("text: memory sizes in MB below a GB, in GB from there") {
  CHECK(handscs::bytes_text(850e6) == "850 MB");
  CHECK(handscs::bytes_text(999.4e6) == "999 MB");
  CHECK(handscs::bytes_text(1e9) == "1.0 GB");
  CHECK(handscs::bytes_text(4.6e9) == "4.6 GB");
}
