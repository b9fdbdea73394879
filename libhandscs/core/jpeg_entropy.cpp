#include "core/jpeg_entropy.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace handscs {
namespace {

// Marker codes (ITU T.81 table B.1).
constexpr uint8_t kSof0 = 0xC0, kSof1 = 0xC1, kSof2 = 0xC2, kDht = 0xC4, kDac = 0xCC;
constexpr uint8_t kRst0 = 0xD0, kRst7 = 0xD7, kEoi = 0xD9, kSos = 0xDA, kDri = 0xDD;

// A frame header SOF0-SOF15 (C0-CF without DHT C4, the reserved JPG C8 and DAC CC).
constexpr bool is_frame_header(uint8_t m) { return m >= 0xC0 && m <= 0xCF && m != kDht && m != 0xC8 && m != kDac; }

// Codes of up to this many bits are decoded by one table lookup (most of a JPEG's codes are).
constexpr int kFastBits = 9;

// A Huffman table in the form of T.81 F.2.2.3: per code length, the first and largest code and
// the index of the first value; plus `fast`, what that search gives for each kFastBits-bit prefix.
struct HuffmanTable {
  bool defined = false;
  std::array<int32_t, 17> max_code{};  // -1: no code of this length
  std::array<int32_t, 17> first_code{};
  std::array<int32_t, 17> first_index{};
  std::vector<uint8_t> values;
  std::array<uint16_t, 1 << kFastBits> fast{};  // (length << 8) | value; 0: search further
};

struct Component {
  int id = 0, h = 1, v = 1;
  int64_t blocks_wide = 0, blocks_high = 0;  // the component's own blocks (T.81 A.1.1)
  int64_t padded_wide = 0;                   // blocks per row of whole MCUs (interleaved scans)
  int dc_table = 0, ac_table = 0;
  std::vector<uint64_t> nonzero;  // progressive: bit k set once coefficient k of a block is nonzero
};

// Bits of the entropy-coded data: 0xFF 0x00 is a data byte 0xFF; any other 0xFF xx is a marker,
// where the data ends (reading past it fails). Up to 64 bits are buffered ahead; pos() is where a
// reader taking one byte at a time would stand (just past the last byte a consumed bit came from),
// which the problem messages report.
class BitReader {
 public:
  BitReader(const uint8_t* bytes, size_t size, size_t pos) : bytes_(bytes), size_(size) { seek(pos); }

  // At least `count` (<= 57) bits buffered, unless the data ends first.
  bool has(int count) {
    if (count_ < count) fill();
    return count_ >= count;
  }
  uint32_t peek(int count) const { return static_cast<uint32_t>(buffer_ >> (64 - count)); }  // 1..32, has(count)
  void consume(int count) {  // has(count), so count <= 57 and the shift is defined
    buffer_ <<= count;
    count_ -= count;
    consumed_ += count;
  }
  bool bit(int& out) {
    if (!has(1)) return false;
    out = static_cast<int>(peek(1));
    consume(1);
    return true;
  }
  // `count` bits as a number; false, having taken the bits there were, when the data ends first.
  bool bits(int count, int32_t& value) {
    if (count == 0) {
      value = 0;
      return true;
    }
    if (has(count)) {
      value = static_cast<int32_t>(peek(count));
      consume(count);
      return true;
    }
    value = 0;
    for (int i = 0; i < count; ++i) {
      int b;
      if (!bit(b)) return false;
      value = (value << 1) | b;
    }
    return true;
  }
  void align() { consume(static_cast<int>((8 - consumed_ % 8) % 8)); }  // drops the padding bits before a marker
  size_t pos() const {
    const int64_t bytes_touched = (consumed_ + 7) / 8;
    return bytes_touched == 0 ? start_ : byte_end_[(bytes_touched - 1) % kRing];
  }
  void seek(size_t pos) {
    start_ = next_ = pos;
    buffer_ = 0;
    count_ = 0;
    consumed_ = 0;
    loaded_ = 0;
  }

 private:
  static constexpr int64_t kRing = 16;  // > the 9 bytes buffered and partly consumed at most

  void fill() {
    while (count_ <= 56 && next_ < size_) {
      const uint8_t b = bytes_[next_];
      if (b == 0xFF) {
        if (next_ + 1 >= size_ || bytes_[next_ + 1] != 0x00) return;  // a marker
        next_ += 2;
      } else {
        ++next_;
      }
      buffer_ |= uint64_t{b} << (56 - count_);
      count_ += 8;
      byte_end_[loaded_++ % kRing] = next_;
    }
  }

  const uint8_t* bytes_;
  size_t size_;
  size_t start_ = 0, next_ = 0;  // where the last seek put the reader; the next byte to buffer
  uint64_t buffer_ = 0;          // buffered bits, the next one highest
  int count_ = 0;                // buffered bits
  int64_t consumed_ = 0;         // bits taken since the seek
  // Bytes buffered since the seek, i.e. (consumed_ + count_) / 8: deriving it instead, with bits()'s
  // one-shot path limited to 32 bits, measured 3-5% slower (handscs-bench-jpeg, 3 alternated runs),
  // so the counter stays.
  int64_t loaded_ = 0;
  std::array<size_t, kRing> byte_end_{};  // by byte number since the seek: the offset after it
};

constexpr int kEnded = -1;     // decode(): the data ended (a marker)
constexpr int kNoMatch = -2;   // decode(): no code of the table matches

// The value of an l-bit `code` if a code of length l matches it; -1 if none does (search on), and
// kNoMatch for a table whose codes of that length run past its values (a malformed DHT).
int match(const HuffmanTable& table, int length, int32_t code) {
  if (table.max_code[length] < 0 || code > table.max_code[length]) return -1;
  const int32_t index = table.first_index[length] + code - table.first_code[length];
  return index >= 0 && index < static_cast<int32_t>(table.values.size()) ? table.values[index] : kNoMatch;
}

int decode(BitReader& reader, const HuffmanTable& table) {
  if (reader.has(16)) {  // the usual case: one lookup, or a search over the 16 bits ahead
    const uint32_t ahead = reader.peek(16);
    const uint16_t entry = table.fast[ahead >> (16 - kFastBits)];
    if (entry != 0) {
      reader.consume(entry >> 8);
      return entry & 0xFF;
    }
    for (int length = 1; length <= 16; ++length) {
      const int value = match(table, length, static_cast<int32_t>(ahead >> (16 - length)));
      if (value == -1) continue;
      reader.consume(length);
      return value;
    }
    reader.consume(16);
    return kNoMatch;
  }
  int32_t code = 0;  // near the end of the data: bit by bit, to report where it ends
  for (int length = 1; length <= 16; ++length) {
    int b;
    if (!reader.bit(b)) return kEnded;
    code = (code << 1) | b;
    const int value = match(table, length, code);
    if (value != -1) return value;
  }
  return kNoMatch;
}

// Fills table.fast from the search tables: each prefix gets what decode's search finds within
// kFastBits bits (0 when it would search further or the table is malformed there).
void build_fast_lookup(HuffmanTable& table) {
  for (uint32_t prefix = 0; prefix < table.fast.size(); ++prefix) {
    table.fast[prefix] = 0;
    for (int length = 1; length <= kFastBits; ++length) {
      const int value = match(table, length, static_cast<int32_t>(prefix >> (kFastBits - length)));
      if (value == -1) continue;
      if (value >= 0) table.fast[prefix] = static_cast<uint16_t>((length << 8) | value);
      break;
    }
  }
}

// Reads a DHT segment's tables; false when malformed.
bool read_tables(const uint8_t* p, size_t length, std::array<HuffmanTable, 8>& tables) {
  size_t at = 0;
  while (at < length) {
    const int table_class = p[at] >> 4, id = p[at] & 15;
    if (table_class > 1 || id > 3 || at + 17 > length) return false;
    int total = 0;
    for (int l = 1; l <= 16; ++l) total += p[at + l];
    if (at + 17 + total > length || total > 256) return false;
    HuffmanTable& t = tables[table_class * 4 + id];
    t = HuffmanTable{};
    t.defined = true;
    t.values.assign(p + at + 17, p + at + 17 + total);
    int32_t code = 0, index = 0;
    for (int l = 1; l <= 16; ++l) {
      const int count = p[at + l];
      t.first_code[l] = code;
      t.first_index[l] = index;
      t.max_code[l] = count ? code + count - 1 : -1;
      code = (code + count) << 1;
      index += count;
    }
    build_fast_lookup(t);
    at += 17 + total;
  }
  return true;
}

// One scan of the frame: which blocks it codes, and how (T.81 annex F for sequential, G for
// progressive scans).
struct Scan {
  std::vector<Component*> components;
  int ss = 0, se = 63, ah = 0, al = 0;
  bool progressive = false;
};

class ScanWalker {
 public:
  ScanWalker(const uint8_t* bytes, size_t size, size_t start, const std::array<HuffmanTable, 8>& tables,
             int max_dc_category)
      : bytes_(bytes), size_(size), reader_(bytes, size, start), tables_(tables),
        max_dc_category_(max_dc_category) {}

  // "" or the problem; on success `end` is the offset of the marker after the scan.
  std::string walk(const Scan& scan, int64_t mcus_wide, int64_t mcus_high, int64_t restart_interval,
                   size_t& end) {
    // An interleaved scan codes whole MCUs; a single-component scan the component's own blocks.
    const bool interleaved = scan.components.size() > 1;
    const Component& first = *scan.components[0];
    const int64_t units_wide = interleaved ? mcus_wide : first.blocks_wide;
    const int64_t units = interleaved ? mcus_wide * mcus_high : first.blocks_wide * first.blocks_high;
    int64_t per_unit = 0;
    for (const Component* c : scan.components) per_unit += interleaved ? c->h * c->v : 1;
    blocks_ = units * per_unit;
    block_ = 0;
    eob_run_ = 0;
    for (int64_t unit = 0; unit < units; ++unit) {
      if (restart_interval > 0 && unit > 0 && unit % restart_interval == 0) {
        reader_.align();
        const size_t at = reader_.pos();
        if (at + 1 >= size_ || bytes_[at] != 0xFF || bytes_[at + 1] < kRst0 || bytes_[at + 1] > kRst7)
          return "corrupt image data: a restart interval does not end where its blocks do" + where();
        reader_.seek(at + 2);
        eob_run_ = 0;
      }
      const int64_t unit_x = unit % units_wide, unit_y = unit / units_wide;
      for (Component* c : scan.components) {
        const int bh = interleaved ? c->v : 1, bw = interleaved ? c->h : 1;
        for (int y = 0; y < bh; ++y)
          for (int x = 0; x < bw; ++x, ++block_) {
            const int64_t bx = interleaved ? unit_x * c->h + x : unit_x;
            const int64_t by = interleaved ? unit_y * c->v + y : unit_y;
            uint64_t* flags = scan.progressive ? &c->nonzero[by * c->padded_wide + bx] : nullptr;
            const bool ok = !scan.progressive ? sequential_block(*c)
                            : scan.ss == 0   ? dc_block(*c, scan)
                            : scan.ah == 0   ? ac_first_block(*c, scan, *flags)
                                             : ac_refine_block(*c, scan, *flags);
            if (!ok) return problem_;
          }
      }
    }
    // The scan must end here: padding bits, then a marker with no coded data left over.
    reader_.align();
    size_t at = reader_.pos(), extra = 0;
    while (at < size_ && !(bytes_[at] == 0xFF && at + 1 < size_ && bytes_[at + 1] != 0x00)) {
      at += bytes_[at] == 0xFF ? 2 : 1;
      ++extra;
    }
    if (extra > 0)
      return "corrupt image data: " + std::to_string(extra) + " bytes left over after the last block (byte " +
             std::to_string(reader_.pos()) + ")";
    end = at;
    return "";
  }

 private:
  // The block functions return false with problem_ set; the messages are built only then.
  std::string where() const {
    return " at block " + std::to_string(block_ + 1) + " of " + std::to_string(blocks_) + " (byte " +
           std::to_string(reader_.pos()) + ")";
  }
  bool fail(const std::string& problem) {
    problem_ = problem + where();
    return false;
  }
  bool ended() { return fail("truncated image data: it ends"); }

  // A symbol of `table`.
  bool symbol(const HuffmanTable& table, int& value) {
    value = decode(reader_, table);
    if (value == kEnded) return ended();
    if (value == kNoMatch) return fail("corrupt image data: no Huffman code matches");
    return true;
  }
  bool skip(int count) {
    int32_t ignored;
    return reader_.bits(count, ignored) || ended();
  }

  bool dc_difference(const Component& c) {
    int s;
    if (!symbol(tables_[c.dc_table], s)) return false;
    if (s > max_dc_category_) return fail("corrupt image data: a DC difference of category " + std::to_string(s));
    return skip(s);
  }

  bool sequential_block(const Component& c) {
    if (!dc_difference(c)) return false;
    for (int k = 1; k < 64;) {
      int rs;
      if (!symbol(tables_[4 + c.ac_table], rs)) return false;
      const int run = rs >> 4, size = rs & 15;
      if (size == 0) {
        if (run != 15) break;  // end of block
        k += 16;
        continue;
      }
      k += run;
      if (k > 63) return fail("corrupt image data: a coefficient run past 63");
      if (!skip(size)) return false;
      ++k;
    }
    return true;
  }

  bool dc_block(const Component& c, const Scan& scan) {
    if (scan.ah == 0) return dc_difference(c);
    return skip(1);  // one refinement bit
  }

  bool ac_first_block(const Component& c, const Scan& scan, uint64_t& flags) {
    if (eob_run_ > 0) {
      --eob_run_;
      return true;
    }
    for (int k = scan.ss; k <= scan.se;) {
      int rs;
      if (!symbol(tables_[4 + c.ac_table], rs)) return false;
      const int run = rs >> 4, size = rs & 15;
      if (size == 0) {
        if (run == 15) {
          k += 16;
          continue;
        }
        int32_t extra = 0;
        if (!reader_.bits(run, extra)) return ended();
        eob_run_ = (int64_t{1} << run) + extra - 1;  // this block ends the run's first band
        break;
      }
      k += run;
      if (k > scan.se) return fail("corrupt image data: a coefficient run past the band's end");
      if (!skip(size)) return false;
      flags |= uint64_t{1} << k;
      ++k;
    }
    return true;
  }

  // Successive approximation of AC coefficients (T.81 G.1.2.3): correction bits for the
  // coefficients already nonzero, new ones of magnitude 1 placed after `run` zero coefficients.
  bool ac_refine_block(const Component& c, const Scan& scan, uint64_t& flags) {
    int k = scan.ss;
    if (eob_run_ == 0) {
      for (; k <= scan.se; ++k) {
        int rs;
        if (!symbol(tables_[4 + c.ac_table], rs)) return false;
        int run = rs >> 4;
        const int size = rs & 15;
        if (size == 0 && run != 15) {
          int32_t extra = 0;
          if (!reader_.bits(run, extra)) return ended();
          eob_run_ = (int64_t{1} << run) + extra;
          break;  // the rest of the band is refined as in an end-of-band run
        }
        if (size > 1) return fail("corrupt image data: a refinement coefficient of size " + std::to_string(size));
        if (size == 1 && !skip(1)) return false;  // the new coefficient's sign
        // Skip `run` zero coefficients, refining the nonzero ones passed on the way.
        for (; k <= scan.se; ++k) {
          if (flags & (uint64_t{1} << k)) {
            if (!skip(1)) return false;
          } else {
            if (run == 0) break;
            --run;
          }
        }
        if (size == 1) {
          if (k > scan.se) return fail("corrupt image data: a coefficient run past the band's end");
          flags |= uint64_t{1} << k;
        }
      }
    }
    if (eob_run_ > 0) {
      for (; k <= scan.se; ++k)
        if ((flags & (uint64_t{1} << k)) && !skip(1)) return false;
      --eob_run_;
    }
    return true;
  }

  const uint8_t* bytes_;
  size_t size_;
  BitReader reader_;
  const std::array<HuffmanTable, 8>& tables_;
  int max_dc_category_;
  int64_t blocks_ = 0, block_ = 0, eob_run_ = 0;
  std::string problem_;
};

}  // namespace

std::string jpeg_entropy_problem(const std::string& file_bytes) {
  const auto* bytes = reinterpret_cast<const uint8_t*>(file_bytes.data());
  const size_t n = file_bytes.size();
  std::array<HuffmanTable, 8> tables;  // DC 0-3, AC 0-3
  std::vector<Component> components;
  int64_t width = 0, height = 0, mcus_wide = 0, mcus_high = 0, restart_interval = 0;
  int max_dc_category = 11;  // precision + 3 (T.81 F.1.2.1): 11 for 8-bit samples, 15 for 12-bit
  bool walkable = false, progressive = false;
  const auto ceil_div = [](int64_t a, int64_t b) { return (a + b - 1) / b; };
  size_t pos = 2;
  while (pos + 4 <= n) {
    while (pos < n && bytes[pos] == 0xFF) ++pos;  // marker and fill bytes
    if (pos + 2 >= n) break;
    const uint8_t marker = bytes[pos++];
    if (marker == kEoi) return "";
    const size_t length = (static_cast<size_t>(bytes[pos]) << 8) | bytes[pos + 1];
    if (length < 2 || pos + length > n) return "";  // the structural check reports these
    const uint8_t* body = bytes + pos + 2;
    const size_t body_length = length - 2;
    pos += length;
    if (is_frame_header(marker)) {
      // Huffman-coded sequential and progressive frames are walked; lossless and arithmetic
      // coding are not, nor a height given later by a DNL marker.
      walkable = marker == kSof0 || marker == kSof1 || marker == kSof2;
      progressive = marker == kSof2;
      if (!walkable || body_length < 6) return "";
      max_dc_category = body[0] + 3;
      height = (body[1] << 8) | body[2];
      width = (body[3] << 8) | body[4];
      const int count = body[5];
      if (height == 0 || width == 0 || count == 0 || body_length < 6 + 3 * static_cast<size_t>(count))
        return "";
      components.assign(count, Component{});
      int h_max = 1, v_max = 1;
      for (int c = 0; c < count; ++c) {
        components[c].id = body[6 + 3 * c];
        components[c].h = std::clamp(body[7 + 3 * c] >> 4, 1, 4);
        components[c].v = std::clamp(body[7 + 3 * c] & 15, 1, 4);
        h_max = std::max(h_max, components[c].h);
        v_max = std::max(v_max, components[c].v);
      }
      mcus_wide = ceil_div(width, 8 * h_max);
      mcus_high = ceil_div(height, 8 * v_max);
      for (auto& c : components) {
        c.blocks_wide = ceil_div(ceil_div(width * c.h, h_max), 8);
        c.blocks_high = ceil_div(ceil_div(height * c.v, v_max), 8);
        c.padded_wide = mcus_wide * c.h;
        if (progressive) c.nonzero.assign(static_cast<size_t>(c.padded_wide * mcus_high * c.v), 0);
      }
    } else if (marker == kDht) {
      if (!read_tables(body, body_length, tables)) return "corrupt: malformed Huffman table";
    } else if (marker == kDri && body_length >= 2) {
      restart_interval = (body[0] << 8) | body[1];
    } else if (marker == kSos) {
      if (!walkable || body_length < 1) return "";
      const int count = body[0];
      if (count < 1 || body_length < 1 + 2 * static_cast<size_t>(count) + 3)
        return "corrupt: malformed scan header";
      Scan scan;
      scan.progressive = progressive;
      const uint8_t* tail = body + 1 + 2 * count;
      if (progressive) {
        scan.ss = tail[0], scan.se = tail[1], scan.ah = tail[2] >> 4, scan.al = tail[2] & 15;
        if (scan.se > 63 || scan.ss > scan.se || (scan.ss == 0 && scan.se != 0) || (scan.ss > 0 && count != 1))
          return "corrupt: a progressive scan header out of range";
      }
      for (int c = 0; c < count; ++c) {
        auto it = std::find_if(components.begin(), components.end(),
                               [&](const Component& k) { return k.id == body[1 + 2 * c]; });
        if (it == components.end()) return "corrupt: the scan names a component the frame lacks";
        it->dc_table = body[2 + 2 * c] >> 4;
        it->ac_table = body[2 + 2 * c] & 15;
        // The tables this scan decodes with must exist: DC for DC-difference scans, AC for the rest.
        const bool needs_dc = !progressive || (scan.ss == 0 && scan.ah == 0);
        const bool needs_ac = !progressive || scan.ss > 0;
        if (it->dc_table > 3 || it->ac_table > 3 || (needs_dc && !tables[it->dc_table].defined) ||
            (needs_ac && !tables[4 + it->ac_table].defined))
          return "corrupt: the scan uses a Huffman table that is not defined";
        scan.components.push_back(&*it);
      }
      ScanWalker walker(bytes, n, pos, tables, max_dc_category);
      size_t end = pos;
      const std::string problem = walker.walk(scan, mcus_wide, mcus_high, restart_interval, end);
      if (!problem.empty()) return problem;
      pos = end;
    }
  }
  return "";
}

}  // namespace handscs
