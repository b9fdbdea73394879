// core/file_stamp.h, what the caches identify a file's version by: the size of the bytes written and
// the modification time set here with utimensat (to the nanosecond), a change of either, and a
// missing file, which leaves the stamp as it was.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "core/file_stamp.h"
#include "test_support.h"

namespace {

void set_mtime(const std::string& path, int64_t seconds, int64_t nanoseconds) {
  const timespec times[2] = {{seconds, nanoseconds}, {seconds, nanoseconds}};
  REQUIRE(::utimensat(AT_FDCWD, path.c_str(), times, 0) == 0);
}

}  // namespace

TEST_CASE("file stamp: size and modification time to the nanosecond") {
  const std::string path = handscs_test::scratch_file("handscs_test_file_stamp", "a.txt", "twelve bytes");
  set_mtime(path, 1700000000, 123456789);
  handscs::FileStamp stamp;
  REQUIRE(handscs::read_file_stamp(path, stamp));
  CHECK(stamp.size == 12);
  CHECK(stamp.mtime_ns == 1700000000123456789LL);

  // Another time, or another size at the same time: another version.
  handscs::FileStamp later;
  set_mtime(path, 1700000000, 123456790);
  REQUIRE(handscs::read_file_stamp(path, later));
  CHECK(later != stamp);
  handscs_test::scratch_file("handscs_test_file_stamp", "a.txt", "thirteen byte");
  set_mtime(path, 1700000000, 123456789);
  handscs::FileStamp longer;
  REQUIRE(handscs::read_file_stamp(path, longer));
  CHECK(longer.size == 13);
  CHECK(longer.mtime_ns == stamp.mtime_ns);
  CHECK(longer != stamp);

  // A file that is not there: false, the stamp as it was.
  handscs::FileStamp kept = stamp;
  CHECK_FALSE(handscs::read_file_stamp(path + ".missing", kept));
  CHECK(kept == stamp);
  ::unlink(path.c_str());
}
