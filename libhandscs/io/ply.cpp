#include "io/ply.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <sstream>
#include <vector>

#include <torch/types.h>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

namespace {

enum class Format { ascii, binary_le, binary_be };

struct ScalarType {
  int size = 0;
  bool is_float = false, is_signed = false;
};

bool parse_type(const std::string& name, ScalarType& t) {
  static const std::map<std::string, ScalarType> types = {
      {"char", {1, false, true}},    {"int8", {1, false, true}},     {"uchar", {1, false, false}},
      {"uint8", {1, false, false}},  {"short", {2, false, true}},    {"int16", {2, false, true}},
      {"ushort", {2, false, false}}, {"uint16", {2, false, false}},  {"int", {4, false, true}},
      {"int32", {4, false, true}},   {"uint", {4, false, false}},    {"uint32", {4, false, false}},
      {"float", {4, true, true}},    {"float32", {4, true, true}},   {"double", {8, true, true}},
      {"float64", {8, true, true}}};
  const auto it = types.find(name);
  if (it == types.end()) return false;
  t = it->second;
  return true;
}

struct Property {
  std::string name;
  ScalarType type;
  bool is_list = false;
  ScalarType count_type;
};

struct Element {
  std::string name;
  int64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::ascii;
  std::vector<Element> elements;
  size_t data_offset = 0;  // first byte after "end_header\n"
  int data_line = 0;       // 1-based line number of the first data line (ascii)
};

[[noreturn]] void fail(const std::string& path, const std::string& message) { throw Error(path + ": " + message); }

Header parse_header(const std::string& path, const std::string& bytes) {
  Header h;
  size_t pos = 0;
  int line_no = 0;
  bool have_format = false;
  auto next_line = [&](std::string& line) {
    if (pos >= bytes.size()) return false;
    size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(end + 1, bytes.size());
    ++line_no;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply")
    fail(path, "not a PLY file (first line is '" + line.substr(0, 40) + "', expected 'ply')");
  while (true) {
    if (!next_line(line)) fail(path, "truncated header (no end_header line)");
    std::istringstream in(line);
    std::string keyword;
    in >> keyword;
    const std::string where = "header line " + std::to_string(line_no) + " '" + line + "'";
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      std::string format, version;
      in >> format >> version;
      if (format == "ascii") h.format = Format::ascii;
      else if (format == "binary_little_endian") h.format = Format::binary_le;
      else if (format == "binary_big_endian") h.format = Format::binary_be;
      else fail(path, "unsupported PLY format '" + format + "' (" + where + ")");
      have_format = true;
    } else if (keyword == "element") {
      Element e;
      std::string count, extra;
      in >> e.name >> count;
      char* end = nullptr;
      const long long n = count.empty() ? -1 : std::strtoll(count.c_str(), &end, 10);
      if (e.name.empty() || count.empty() || *end != '\0' || n < 0 || (in >> extra))
        fail(path, "malformed element line (" + where + ")");
      e.count = n;
      h.elements.push_back(e);
    } else if (keyword == "property") {
      if (h.elements.empty()) fail(path, "property before any element (" + where + ")");
      Property p;
      std::string type, extra;
      in >> type;
      if (type == "list") {
        std::string count_type, item_type;
        in >> count_type >> item_type >> p.name;
        p.is_list = true;
        if (!parse_type(count_type, p.count_type) || p.count_type.is_float)
          fail(path, "unknown list count type '" + count_type + "' (" + where + ")");
        if (!parse_type(item_type, p.type)) fail(path, "unknown property type '" + item_type + "' (" + where + ")");
      } else {
        in >> p.name;
        if (!parse_type(type, p.type)) fail(path, "unknown property type '" + type + "' (" + where + ")");
      }
      if (p.name.empty() || (in >> extra)) fail(path, "malformed property line (" + where + ")");
      for (const Property& q : h.elements.back().properties)
        if (q.name == p.name) fail(path, "duplicate property '" + p.name + "' (" + where + ")");
      h.elements.back().properties.push_back(p);
    } else {
      fail(path, "unknown header keyword '" + keyword + "' (" + where + ")");
    }
  }
  if (!have_format) fail(path, "header has no format line");
  h.data_offset = pos;
  h.data_line = line_no + 1;
  return h;
}

// Reads one binary scalar of type t at p (file byte order per `format`) as double.
double read_scalar(const char* p, const ScalarType& t, Format format) {
  unsigned char b[8];
  std::memcpy(b, p, t.size);
  if (format == Format::binary_be) std::reverse(b, b + t.size);
  if (t.is_float) {
    if (t.size == 4) {
      float v;
      std::memcpy(&v, b, 4);
      return v;
    }
    double v;
    std::memcpy(&v, b, 8);
    return v;
  }
  switch (t.size) {
    case 1: return t.is_signed ? double(int8_t(b[0])) : double(b[0]);
    case 2: {
      uint16_t u;
      std::memcpy(&u, b, 2);
      return t.is_signed ? double(int16_t(u)) : double(u);
    }
    default: {
      uint32_t u;
      std::memcpy(&u, b, 4);
      return t.is_signed ? double(int32_t(u)) : double(u);
    }
  }
}

// Where each needed vertex property goes: column `col` of output `slot` (-1: not needed).
struct Column {
  int slot = -1, col = 0;
};

enum Slot { kMeans, kDc, kRest, kOpacity, kScales, kRot, kNumSlots };

}  // namespace

GaussianPly read_gaussian_ply(const std::string& path) {
  // 62 floats a Gaussian: 64 GB is 270 million Gaussians, beyond any scene this tool renders.
  const std::string bytes = read_file(path, std::uintmax_t{64} << 30);
  const Header h = parse_header(path, bytes);

  const Element* vertex = nullptr;
  for (const Element& e : h.elements)
    if (e.name == "vertex") vertex = &e;
  if (!vertex) fail(path, "no 'vertex' element in the header");

  // Map property names to output columns; f_rest_k must be numbered 0..K-1.
  std::vector<Column> columns(vertex->properties.size());
  std::map<std::string, Column> wanted = {
      {"x", {kMeans, 0}},      {"y", {kMeans, 1}},      {"z", {kMeans, 2}},      {"f_dc_0", {kDc, 0}},
      {"f_dc_1", {kDc, 1}},    {"f_dc_2", {kDc, 2}},    {"opacity", {kOpacity, 0}}, {"scale_0", {kScales, 0}},
      {"scale_1", {kScales, 1}}, {"scale_2", {kScales, 2}}, {"rot_0", {kRot, 0}},  {"rot_1", {kRot, 1}},
      {"rot_2", {kRot, 2}},    {"rot_3", {kRot, 3}}};
  const std::vector<std::string> required = {"x",       "y",       "z",       "f_dc_0", "f_dc_1",
                                             "f_dc_2",  "opacity", "scale_0", "scale_1", "scale_2",
                                             "rot_0",   "rot_1",   "rot_2",   "rot_3"};
  std::vector<int> rest_ids;
  std::vector<std::string> found;
  for (size_t k = 0; k < vertex->properties.size(); ++k) {
    const Property& p = vertex->properties[k];
    const auto it = wanted.find(p.name);
    if (it != wanted.end()) {
      if (p.is_list) fail(path, "vertex property '" + p.name + "' is a list, expected a scalar");
      columns[k] = it->second;
      found.push_back(p.name);
    } else if (p.name.rfind("f_rest_", 0) == 0 && !p.is_list) {
      const std::string digits = p.name.substr(7);
      if (!digits.empty() && std::all_of(digits.begin(), digits.end(), ::isdigit) && digits.size() < 6) {
        columns[k] = {kRest, std::stoi(digits)};
        rest_ids.push_back(std::stoi(digits));
      }
    }
  }
  std::string missing;
  for (const std::string& name : required)
    if (std::find(found.begin(), found.end(), name) == found.end()) missing += (missing.empty() ? "" : ", ") + name;
  if (!missing.empty()) fail(path, "vertex element is missing properties: " + missing);
  std::sort(rest_ids.begin(), rest_ids.end());
  for (size_t i = 0; i < rest_ids.size(); ++i)
    if (rest_ids[i] != int(i)) fail(path, "f_rest properties are not numbered 0.." + std::to_string(rest_ids.size() - 1));
  const int64_t rest = int64_t(rest_ids.size());

  const int64_t n = vertex->count;
  // Every row takes at least one byte: a count beyond the file size is a wrong header, not an allocation request.
  if (size_t(n) > bytes.size() - h.data_offset)
    fail(path, "truncated data: element 'vertex' declares " + std::to_string(n) + " rows but the file has only " +
                   std::to_string(bytes.size() - h.data_offset) + " bytes of data");
  const int widths[kNumSlots] = {3, 3, int(rest), 1, 3, 4};
  std::vector<std::vector<float>> out(kNumSlots);
  for (int s = 0; s < kNumSlots; ++s) out[s].assign(size_t(n) * widths[s], 0.0f);
  auto store = [&](const Column& c, int64_t row, double v) {
    if (c.slot >= 0) out[c.slot][size_t(row) * widths[c.slot] + c.col] = float(v);
  };

  if (h.format == Format::ascii) {
    size_t pos = h.data_offset;
    int line_no = h.data_line;
    auto next_line = [&](std::string& line) {
      while (pos < bytes.size()) {
        size_t end = bytes.find('\n', pos);
        if (end == std::string::npos) end = bytes.size();
        line = bytes.substr(pos, end - pos);
        pos = end + 1;
        ++line_no;
        if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
      }
      return false;
    };
    std::string line;
    for (const Element& e : h.elements) {
      for (int64_t row = 0; row < e.count; ++row) {
        if (!next_line(line))
          fail(path, "truncated data: element '" + e.name + "' declares " + std::to_string(e.count) +
                         " rows but the file ends after " + std::to_string(row));
        std::istringstream in(line);
        const std::string where = "line " + std::to_string(line_no - 1) + " (" + e.name + " " + std::to_string(row) + ")";
        for (size_t k = 0; k < e.properties.size(); ++k) {
          const Property& p = e.properties[k];
          double count = 1;
          if (p.is_list && !(in >> count)) fail(path, where + ": missing list length of '" + p.name + "'");
          for (int64_t j = 0; j < int64_t(count); ++j) {
            std::string token;
            if (!(in >> token)) fail(path, where + ": expected more values (missing '" + p.name + "')");
            char* end = nullptr;
            const double v = std::strtod(token.c_str(), &end);
            if (*end != '\0') fail(path, where + ": '" + token + "' is not a number (property '" + p.name + "')");
            if (&e == vertex && !p.is_list) store(columns[k], row, v);
          }
        }
        std::string extra;
        if (in >> extra) fail(path, where + ": more values than the header's properties ('" + extra + "')");
      }
    }
    if (next_line(line))
      fail(path, "unexpected data after the last element at line " + std::to_string(line_no - 1) +
                     " (wrong element count in the header?)");
  } else {
    size_t pos = h.data_offset;
    for (const Element& e : h.elements) {
      bool fixed = true;
      size_t stride = 0;
      for (const Property& p : e.properties) {
        fixed = fixed && !p.is_list;
        stride += p.type.size;
      }
      if (fixed && stride > 0 && size_t(e.count) > (bytes.size() - pos) / stride) {
        fail(path, "truncated data: element '" + e.name + "' declares " + std::to_string(e.count) + " rows (" +
                       std::to_string(stride * size_t(e.count)) + " bytes) but only " +
                       std::to_string((bytes.size() - pos) / std::max<size_t>(stride, 1)) +
                       " complete rows follow");
      }
      for (int64_t row = 0; row < e.count; ++row) {
        for (size_t k = 0; k < e.properties.size(); ++k) {
          const Property& p = e.properties[k];
          int64_t count = 1;
          if (p.is_list) {
            if (bytes.size() - pos < size_t(p.count_type.size))
              fail(path, "truncated data in element '" + e.name + "' row " + std::to_string(row));
            count = int64_t(read_scalar(bytes.data() + pos, p.count_type, h.format));
            pos += p.count_type.size;
          }
          if (count < 0 || bytes.size() - pos < size_t(count) * p.type.size)
            fail(path, "truncated data in element '" + e.name + "' row " + std::to_string(row));
          if (&e == vertex && !p.is_list) store(columns[k], row, read_scalar(bytes.data() + pos, p.type, h.format));
          pos += size_t(count) * p.type.size;
        }
      }
    }
    if (pos != bytes.size())
      fail(path, std::to_string(bytes.size() - pos) +
                     " bytes of unexpected data after the last element (wrong element count in the header?)");
  }

  auto tensor = [&](int slot, std::vector<int64_t> shape) {
    auto t = torch::empty(shape, torch::kFloat32);
    std::copy(out[slot].begin(), out[slot].end(), t.data_ptr<float>());
    return t;
  };
  GaussianPly g;
  g.means = tensor(kMeans, {n, 3});
  g.f_dc = tensor(kDc, {n, 3});
  if (rest > 0) g.f_rest = tensor(kRest, {n, rest});
  g.opacity_logits = tensor(kOpacity, {n});
  g.log_scales = tensor(kScales, {n, 3});
  g.rotations = tensor(kRot, {n, 4});
  return g;
}

void write_gaussian_ply(const std::string& path, const GaussianPly& g) {
  const int64_t n = g.size();
  auto check = [&](const torch::Tensor& t, const char* name, int64_t width) {
    if (!t.defined() || t.dim() < 1 || t.size(0) != n || t.numel() != n * width)
      fail(path, std::string("cannot write: ") + name + " must hold " + std::to_string(n) + " x " +
                     std::to_string(width) + " values" +
                     (t.defined() ? ", got shape " + c10::str(t.sizes()) : ", got an undefined tensor"));
    return t.detach().to(torch::kCPU, torch::kFloat32).contiguous().view({n, width});
  };
  const auto means = check(g.means, "means", 3), dc = check(g.f_dc, "f_dc", 3);
  const auto opacity = check(g.opacity_logits, "opacity_logits", 1), scales = check(g.log_scales, "log_scales", 3);
  const auto rot = check(g.rotations, "rotations", 4);
  const int64_t rest_k = g.f_rest.defined() && g.f_rest.dim() == 2 ? g.f_rest.size(1) : 0;
  const auto rest = rest_k > 0 ? check(g.f_rest, "f_rest", rest_k) : torch::Tensor();

  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\nelement vertex " << n << "\n";
  for (const char* name : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    header << "property float " << name << "\n";
  for (int64_t k = 0; k < rest_k; ++k) header << "property float f_rest_" << k << "\n";
  for (const char* name : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    header << "property float " << name << "\n";
  header << "end_header\n";
  std::string bytes = header.str();
  const int64_t row_floats = 3 + 3 + 3 + rest_k + 1 + 3 + 4;
  std::vector<float> data(size_t(n * row_floats));
  const float *m = means.data_ptr<float>(), *d = dc.data_ptr<float>(), *o = opacity.data_ptr<float>();
  const float *s = scales.data_ptr<float>(), *r = rot.data_ptr<float>();
  const float* fr = rest_k > 0 ? rest.data_ptr<float>() : nullptr;
  for (int64_t i = 0; i < n; ++i) {
    float* row = data.data() + i * row_floats;
    std::copy(m + 3 * i, m + 3 * i + 3, row);
    std::fill(row + 3, row + 6, 0.0f);
    std::copy(d + 3 * i, d + 3 * i + 3, row + 6);
    if (fr) std::copy(fr + rest_k * i, fr + rest_k * (i + 1), row + 9);
    row[9 + rest_k] = o[i];
    std::copy(s + 3 * i, s + 3 * i + 3, row + 10 + rest_k);
    std::copy(r + 4 * i, r + 4 * i + 4, row + 13 + rest_k);
  }
  static_assert(sizeof(float) == 4, "PLY float is 4 bytes");
  const uint16_t probe = 1;
  if (*reinterpret_cast<const uint8_t*>(&probe) != 1) fail(path, "cannot write: big-endian hosts are not supported");
  bytes.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(float));
  write_file_atomic(path, bytes);
}

torch::Tensor ply_colors(const GaussianPly& g) { return 0.5 + kShC0 * g.f_dc; }

torch::Tensor ply_opacities(const GaussianPly& g) { return torch::sigmoid(g.opacity_logits); }

torch::Tensor ply_scales(const GaussianPly& g) { return torch::exp(g.log_scales); }

GaussianPly make_gaussian_ply(const torch::Tensor& means, const torch::Tensor& colors, const torch::Tensor& opacities,
                              const torch::Tensor& scales, const torch::Tensor& rotations) {
  GaussianPly g;
  g.means = means.detach().to(torch::kFloat32);
  g.f_dc = ((colors.detach() - 0.5) / kShC0).to(torch::kFloat32);
  g.opacity_logits = torch::logit(opacities.detach().reshape({-1}).clamp(1e-6, 1 - 1e-6)).to(torch::kFloat32);
  g.log_scales = torch::log(scales.detach()).to(torch::kFloat32);
  g.rotations = rotations.detach().to(torch::kFloat32);
  return g;
}

}  // namespace handscs
