// core/byte_stream.h and core/hash.h: values round-trip; truncated data and impossible counts are
// errors, never reads past the end; the checksum keeps the values stored in earlier checkpoints.
#include <catch2/catch.hpp>

#include <array>

#include "core/byte_stream.h"
#include "core/hash.h"

TEST_CASE("byte stream: numbers, arrays and strings round-trip") {
  handscs::ByteWriter out;
  out.put<int64_t>(-1234567890123);
  out.put<double>(0.1);
  const std::array<uint8_t, 3> flags{1, 0, 1};
  out.put_array(flags.data(), flags.size());
  out.put_string("Capture0/0000_synth_rom");
  out.put_string("");
  out.put<uint64_t>(2);
  handscs::ByteReader in(out.bytes().data(), out.bytes().size());
  CHECK(in.get<int64_t>() == -1234567890123);
  CHECK(in.get<double>() == 0.1);
  std::array<uint8_t, 3> back{};
  in.get_array(back.data(), back.size());
  CHECK(back == flags);
  CHECK(in.get_string() == "Capture0/0000_synth_rom");
  CHECK(in.get_string().empty());
  CHECK(in.get_count(0) == 2);
  CHECK(in.remaining() == 0);
  CHECK_THROWS_AS(in.get<uint8_t>(), handscs::ByteStreamError);
}

TEST_CASE("byte stream: truncated data and impossible lengths are errors") {
  handscs::ByteWriter out;
  out.put<uint64_t>(1000);  // a string of 1000 bytes follows... but only 3 do
  out.put_array("abc", 3);
  handscs::ByteReader strings(out.bytes().data(), out.bytes().size());
  CHECK_THROWS_AS(strings.get_string(), handscs::ByteStreamError);

  handscs::ByteReader counts(out.bytes().data(), out.bytes().size());
  CHECK_THROWS_AS(counts.get_count(8), handscs::ByteStreamError);  // 1000 items of 8 bytes in 3

  handscs::ByteReader arrays(out.bytes().data(), 5);
  double values[2];
  CHECK_THROWS_AS(arrays.get_array(values, 2), handscs::ByteStreamError);
  CHECK(arrays.remaining() == 5);  // nothing consumed by the failed read
}

TEST_CASE("hash: FNV-1a with the offset basis earlier checkpoints were written with") {
  // Independent reference: the same recurrence in Python's arbitrary-precision integers,
  // h = ((h ^ byte) * 1099511628211) mod 2^64 from h = 1469598103934665603.
  CHECK(handscs::fnv1a64("") == 1469598103934665603ull);
  CHECK(handscs::fnv1a64("a") == 4953267810257967366ull);
  CHECK(handscs::fnv1a64("handscs") == 2652026528625802449ull);
}
