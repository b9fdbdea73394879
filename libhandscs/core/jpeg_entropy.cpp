#include "core/jpeg_entropy.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/jpeg_markers.h"

namespace handscs {
namespace {

using jpeg::kDht;
using jpeg::kDri;
using jpeg::kEoi;
using jpeg::kRst0;
using jpeg::kRst7;
using jpeg::kSof0;
using jpeg::kSof1;
using jpeg::kSof2;
using jpeg::kSos;

// A Huffman table in the form of T.81 F.2.2.3: per code length, the first and largest code and
// the index of the first value.
struct HuffmanTable {
  bool defined = false;
  std::array<int32_t, 17> max_code{};  // -1: no code of this length
  std::array<int32_t, 17> first_code{};
  std::array<int32_t, 17> first_index{};
  std::vector<uint8_t> values;
};

struct Component {
  int id = 0, h = 1, v = 1;
  int64_t blocks_wide = 0, blocks_high = 0;  // the component's own blocks (T.81 A.1.1)
  int64_t padded_wide = 0;                   // blocks per row of whole MCUs (interleaved scans)
  int dc_table = 0, ac_table = 0;
  std::vector<uint64_t> nonzero;  // progressive: bit k set once coefficient k of a block is nonzero
};

// Bits of the entropy-coded data: 0xFF 0x00 is a data byte 0xFF; any other 0xFF xx is a marker,
// where the data ends (reading past it fails).
class BitReader {
 public:
  BitReader(const uint8_t* bytes, size_t size, size_t pos) : bytes_(bytes), size_(size), pos_(pos) {}

  bool bit(int& out) {
    if (left_ == 0) {
      if (pos_ >= size_) return false;
      const uint8_t b = bytes_[pos_];
      if (b == 0xFF) {
        if (pos_ + 1 >= size_ || bytes_[pos_ + 1] != 0x00) return false;  // a marker
        pos_ += 2;
      } else {
        ++pos_;
      }
      byte_ = b;
      left_ = 8;
    }
    out = (byte_ >> --left_) & 1;
    return true;
  }
  bool bits(int count, int32_t& value) {
    value = 0;
    for (int i = 0; i < count; ++i) {
      int b;
      if (!bit(b)) return false;
      value = (value << 1) | b;
    }
    return true;
  }
  void align() { left_ = 0; }  // drops the padding bits before a marker
  size_t pos() const { return pos_; }
  void seek(size_t pos) { pos_ = pos, left_ = 0; }

 private:
  const uint8_t* bytes_;
  size_t size_, pos_;
  uint8_t byte_ = 0;
  int left_ = 0;
};

constexpr int kEnded = -1;     // decode(): the data ended (a marker)
constexpr int kNoMatch = -2;   // decode(): no code of the table matches

int decode(BitReader& reader, const HuffmanTable& table) {
  int32_t code = 0;
  for (int length = 1; length <= 16; ++length) {
    int b;
    if (!reader.bit(b)) return kEnded;
    code = (code << 1) | b;
    if (table.max_code[length] >= 0 && code <= table.max_code[length])
      return table.values[table.first_index[length] + code - table.first_code[length]];
  }
  return kNoMatch;
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
            const std::string problem = !scan.progressive ? sequential_block(*c)
                                        : scan.ss == 0   ? dc_block(*c, scan)
                                        : scan.ah == 0   ? ac_first_block(*c, scan, *flags)
                                                         : ac_refine_block(*c, scan, *flags);
            if (!problem.empty()) return problem;
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
  std::string where() const {
    return " at block " + std::to_string(block_ + 1) + " of " + std::to_string(blocks_) + " (byte " +
           std::to_string(reader_.pos()) + ")";
  }
  std::string ended() const { return "truncated image data: it ends" + where(); }
  std::string no_match() const { return "corrupt image data: no Huffman code matches" + where(); }

  // A symbol of `table`, or the problem.
  bool symbol(const HuffmanTable& table, int& value, std::string& problem) {
    value = decode(reader_, table);
    if (value == kEnded) problem = ended();
    if (value == kNoMatch) problem = no_match();
    return value >= 0;
  }
  bool skip(int count, std::string& problem) {
    int32_t ignored;
    if (reader_.bits(count, ignored)) return true;
    problem = ended();
    return false;
  }

  std::string dc_difference(const Component& c) {
    std::string problem;
    int s;
    if (!symbol(tables_[c.dc_table], s, problem)) return problem;
    if (s > max_dc_category_)
      return "corrupt image data: a DC difference of category " + std::to_string(s) + where();
    skip(s, problem);
    return problem;
  }

  std::string sequential_block(const Component& c) {
    std::string problem = dc_difference(c);
    if (!problem.empty()) return problem;
    for (int k = 1; k < 64;) {
      int rs;
      if (!symbol(tables_[4 + c.ac_table], rs, problem)) return problem;
      const int run = rs >> 4, size = rs & 15;
      if (size == 0) {
        if (run != 15) break;  // end of block
        k += 16;
        continue;
      }
      k += run;
      if (k > 63) return "corrupt image data: a coefficient run past 63" + where();
      if (!skip(size, problem)) return problem;
      ++k;
    }
    return "";
  }

  std::string dc_block(const Component& c, const Scan& scan) {
    if (scan.ah == 0) return dc_difference(c);
    std::string problem;
    skip(1, problem);  // one refinement bit
    return problem;
  }

  std::string ac_first_block(const Component& c, const Scan& scan, uint64_t& flags) {
    if (eob_run_ > 0) {
      --eob_run_;
      return "";
    }
    std::string problem;
    for (int k = scan.ss; k <= scan.se;) {
      int rs;
      if (!symbol(tables_[4 + c.ac_table], rs, problem)) return problem;
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
      if (k > scan.se) return "corrupt image data: a coefficient run past the band's end" + where();
      if (!skip(size, problem)) return problem;
      flags |= uint64_t{1} << k;
      ++k;
    }
    return "";
  }

  // Successive approximation of AC coefficients (T.81 G.1.2.3): correction bits for the
  // coefficients already nonzero, new ones of magnitude 1 placed after `run` zero coefficients.
  std::string ac_refine_block(const Component& c, const Scan& scan, uint64_t& flags) {
    int k = scan.ss;
    if (eob_run_ == 0) {
      for (; k <= scan.se; ++k) {
        int rs;
        std::string problem;
        if (!symbol(tables_[4 + c.ac_table], rs, problem)) return problem;
        int run = rs >> 4;
        const int size = rs & 15;
        if (size == 0 && run != 15) {
          int32_t extra = 0;
          if (!reader_.bits(run, extra)) return ended();
          eob_run_ = (int64_t{1} << run) + extra;
          break;  // the rest of the band is refined as in an end-of-band run
        }
        if (size > 1) return "corrupt image data: a refinement coefficient of size " + std::to_string(size) + where();
        if (size == 1 && !skip(1, problem)) return problem;  // the new coefficient's sign
        // Skip `run` zero coefficients, refining the nonzero ones passed on the way.
        for (; k <= scan.se; ++k) {
          if (flags & (uint64_t{1} << k)) {
            if (!skip(1, problem)) return problem;
          } else {
            if (run == 0) break;
            --run;
          }
        }
        if (size == 1) {
          if (k > scan.se) return "corrupt image data: a coefficient run past the band's end" + where();
          flags |= uint64_t{1} << k;
        }
      }
    }
    if (eob_run_ > 0) {
      std::string problem;
      for (; k <= scan.se; ++k)
        if ((flags & (uint64_t{1} << k)) && !skip(1, problem)) return problem;
      --eob_run_;
    }
    return "";
  }

  const uint8_t* bytes_;
  size_t size_;
  BitReader reader_;
  const std::array<HuffmanTable, 8>& tables_;
  int max_dc_category_;
  int64_t blocks_ = 0, block_ = 0, eob_run_ = 0;
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
    if (jpeg::is_frame_header(marker)) {
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
