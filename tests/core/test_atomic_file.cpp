// Atomic writes replace a file whole and leave no temporary behind; a file too large for the
// process's memory is named by read_file; a path swapped for a named pipe while it is read never
// blocks the read.
#include "path_swap.h"
#include "test_support.h"

#include <catch2/catch.hpp>

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

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

TEST_CASE("read_file: a file larger than the process may hold is named, not std::bad_alloc") {
  const auto dir = std::filesystem::temp_directory_path() / ("handscs_read_big_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "sparse.bin").string();
  {
    std::ofstream out(path, std::ios::binary);
    out.seekp((std::streamoff{2} << 30) - 1);  // 2 GiB, sparse: no disk used
    out.put('x');
  }
  // In a child whose address space is capped 512 MB above what it maps now, the 2 GiB buffer cannot
  // be allocated; the child reports the message through its exit and a file.
  const std::string result = (dir / "message.txt").string();
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    long pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const rlim_t cap = static_cast<rlim_t>(pages) * sysconf(_SC_PAGESIZE) + (rlim_t{512} << 20);
    const rlimit limit{cap, cap};
    setrlimit(RLIMIT_AS, &limit);
    std::string message = "(no error)";
    try {
      handscs::read_file(path, std::uintmax_t{4} << 30);
    } catch (const std::exception& e) {
      message = e.what();
    }
    std::ofstream(result) << message;
    _exit(0);
  }
  int status = 0;
  waitpid(child, &status, 0);
  REQUIRE(WIFEXITED(status));
  std::ifstream in(result);
  std::string message;
  std::getline(in, message);
  CHECK(message == path + ": 2048 MB do not fit in this process's memory");
  std::filesystem::remove_all(dir);
}

TEST_CASE("read_file: a path swapped between a file and a named pipe never blocks the read") {
  // Each read must return the file's bytes or refuse the pipe, never wait for a writer.
  const auto dir = std::filesystem::temp_directory_path() / ("handscs_swap_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "input.json").string(), file = (dir / "file").string();
  handscs::write_file_atomic(file, "{}");
  const auto read = [&] {
    try {
      return handscs::read_file(path) == "{}" ? handscs_test::SwapRead::file : handscs_test::SwapRead::wrong;
    } catch (const handscs::Error& e) {
      return handscs_test::refusal_or_wrong(e.what(), path);
    }
  };
  // 1: wrong bytes or another error, 3: swap failed, 4: one kind only, -1: a read blocked.
  CHECK(handscs_test::swapped_path_reads(path, file, read, 20000) == 0);
  std::filesystem::remove_all(dir);
}
