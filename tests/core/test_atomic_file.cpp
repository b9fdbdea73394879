// Atomic writes replace a file whole and leave no temporary behind.
#include <catch2/catch.hpp>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"

TEST_CASE("atomic_file: write, overwrite and read back") {
  const auto dir = std::filesystem::temp_directory_path() / "handscs_test_atomic";
  std::filesystem::remove_all(dir);
  handscs::ensure_directory(dir.string());
  const auto path = (dir / "a.bin").string();
  handscs::write_file_atomic(path, std::string("first\0x", 7));
  CHECK(handscs::read_file(path) == std::string("first\0x", 7));
  handscs::write_file_atomic(path, "second");
  CHECK(handscs::read_file(path) == "second");
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    (void)entry;
    ++entries;
  }
  CHECK(entries == 1);
  CHECK_THROWS_WITH(handscs::write_file_atomic((dir / "no/such/dir/f").string(), "x"),
                    Catch::Contains("cannot write"));
  CHECK_THROWS_WITH(handscs::read_file((dir / "missing").string()),
                    Catch::Contains("missing: cannot open file"));
}
