#include "data/json_view.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <memory>
#include <optional>
#include <vector>

#include "core/config.h"
#include "core/error.h"
#include "core/json_keys.h"
#include "core/progress.h"

namespace handscs {

using json = nlohmann::json;

std::string json_kind(const json& value) {
  // As core's json_type_name, with the length of arrays (shape errors read better with it).
  return value.is_array() ? "array of " + std::to_string(value.size()) : json_type_name(value);
}

void JsonView::fail(const std::string& problem) const {
  throw Error(*file_ + ": " + (path_.empty() ? std::string("(top level)") : path_) + ": " +
              problem);
}

std::string JsonView::child(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void JsonView::require_object() const {
  if (!value_->is_object()) fail("expected object, got " + json_kind(*value_));
}

void JsonView::require_known_keys(const std::vector<std::string>& known) const {
  require_object();
  for (auto it = value_->begin(); it != value_->end(); ++it) {
    bool listed = false;
    for (const auto& k : known) listed = listed || k == it.key();
    if (listed) continue;
    std::string names;
    for (const auto& k : known) names += (names.empty() ? "" : ", ") + k;
    fail("unknown key \"" + it.key() + "\" (known: " + names + ")");
  }
}

JsonView JsonView::at(const std::string& key) const {
  require_object();
  auto it = value_->find(key);
  if (it == value_->end()) fail("missing key \"" + key + "\"");
  return JsonView(*it, *file_, child(key));
}

JsonView JsonView::at(size_t index) const {
  if (!value_->is_array() || index >= value_->size())
    fail("expected array with element " + std::to_string(index) + ", got " + json_kind(*value_));
  return JsonView((*value_)[index], *file_, path_ + "[" + std::to_string(index) + "]");
}

size_t JsonView::size() const {
  if (!value_->is_array()) fail("expected array, got " + json_kind(*value_));
  return value_->size();
}

size_t JsonView::array(size_t n) const {
  if (!value_->is_array() || value_->size() != n)
    fail("expected array of " + std::to_string(n) + ", got " + json_kind(*value_));
  return n;
}

double JsonView::number() const {
  if (!value_->is_number()) fail("expected number, got " + json_kind(*value_));
  const double x = value_->get<double>();
  if (!std::isfinite(x)) fail("expected a finite number");
  return x;
}

int64_t JsonView::integer() const {
  if (value_->is_number_integer()) return value_->get<int64_t>();
  if (value_->is_number_float()) {
    const double x = value_->get<double>();
    if (x == std::floor(x) && std::fabs(x) < 9.0e15) return static_cast<int64_t>(x);
    fail("expected integer, got " + value_->dump());
  }
  fail("expected integer, got " + json_kind(*value_));
}

std::string JsonView::string() const {
  if (!value_->is_string()) fail("expected string, got " + json_kind(*value_));
  return value_->get<std::string>();
}

bool JsonView::flag() const {
  if (value_->is_boolean()) return value_->get<bool>();
  if (value_->is_number()) {
    const double x = value_->get<double>();
    if (x == 0.0 || x == 1.0) return x == 1.0;
    fail("expected 0 or 1, got " + value_->dump());
  }
  fail("expected boolean or 0/1, got " + json_kind(*value_));
}

void JsonView::numbers(double* out, size_t n) const {
  array(n);
  for (size_t i = 0; i < n; ++i) out[i] = at(i).number();
}

void JsonView::matrix(double* out, size_t rows, size_t cols) const {
  if (!value_->is_array() || value_->size() != rows)
    fail("expected " + std::to_string(rows) + "x" + std::to_string(cols) + " array, got " +
         json_kind(*value_));
  for (size_t r = 0; r < rows; ++r) at(r).numbers(out + r * cols, cols);
}

void JsonView::flags(uint8_t* out, size_t n) const {
  array(n);
  for (size_t i = 0; i < n; ++i) {
    JsonView item = at(i);
    if (item.raw().is_array()) {
      item.array(1);
      item = item.at(0);
    }
    out[i] = item.flag() ? 1 : 0;
  }
}

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};

[[noreturn]] void throw_parse_error(const std::string& path, const json::parse_error& e) {
  // Line and column of the byte offset nlohmann reports (1-based), found by re-reading the file.
  size_t line = 1, column = 1;
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (file) {
    for (size_t i = 0; i + 1 < e.byte; ++i) {
      const int c = std::fgetc(file.get());
      if (c == EOF) break;
      if (c == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
  }
  throw Error(path + ": malformed JSON at line " + std::to_string(line) + ", column " +
              std::to_string(column) + " (" + e.what() + ")");
}

std::unique_ptr<std::FILE, FileCloser> open_json(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) throw Error(path + ": cannot open file");
  return file;
}

// Files from this size on show a progress line while streamed: InterHand2.6M's data.json (0.7-1.4
// GB) takes tens of seconds; below 64 MiB a read takes about a second and a line would be noise.
constexpr int64_t kProgressMinBytes = int64_t{64} << 20;
constexpr size_t kChunkBytes = size_t{1} << 20;  // fread size: large reads, small buffer

// The file in 1 MiB fread chunks, reporting MB read to an optional progress line. nlohmann reads
// through ChunkIterator one character at a time; its FILE* adapter calls fgetc per character.
class ChunkedFile {
 public:
  ChunkedFile(std::FILE* file, const std::string& path) : file_(file), buffer_(kChunkBytes) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (!ec && static_cast<int64_t>(size) >= kProgressMinBytes)
      progress_.emplace("reading " + std::filesystem::path(path).filename().string() + " (MB)",
                        static_cast<int64_t>(size >> 20), "MB");
  }
  ~ChunkedFile() {
    if (progress_) progress_->finish();
  }
  bool at_end() {
    if (position_ < length_) return false;
    length_ = std::fread(buffer_.data(), 1, buffer_.size(), file_);
    position_ = 0;
    bytes_read_ += static_cast<int64_t>(length_);
    if (progress_) progress_->update(bytes_read_ >> 20);
    return length_ == 0;
  }
  const char& current() const { return buffer_[position_]; }
  void advance() { ++position_; }

 private:
  std::FILE* file_;
  std::vector<char> buffer_;
  size_t position_ = 0, length_ = 0;
  int64_t bytes_read_ = 0;
  std::optional<ProgressBar> progress_;
};

// Input iterator over a ChunkedFile; a default-constructed one is the end.
class ChunkIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  ChunkIterator() = default;
  explicit ChunkIterator(ChunkedFile* file) : file_(file) {}
  reference operator*() const { return file_->current(); }
  ChunkIterator& operator++() {
    file_->advance();
    return *this;
  }
  // Only ever compared with the end iterator.
  bool operator==(const ChunkIterator& other) const { return at_end() == other.at_end(); }
  bool operator!=(const ChunkIterator& other) const { return !(*this == other); }

 private:
  bool at_end() const { return file_ == nullptr || file_->at_end(); }
  ChunkedFile* file_ = nullptr;
};

}  // namespace

json stream_json_elements(const std::string& path,
                          const std::function<bool(const std::string&)>& keep_top,
                          const std::function<void(const JsonElement&)>& visit) {
  auto file = open_json(path);
  bool root_is_object = false;
  bool in_array = false;
  bool skip_top = false;
  std::string top, second;
  int64_t index = 0;
  // nlohmann's depth: the root container's events have depth 0, top-level entries depth 1 and
  // their elements depth 2 (a discarded value is never stored in the result).
  JsonKeyGuard keys(path);
  auto callback = [&](int depth, json::parse_event_t event, json& parsed) -> bool {
    using E = json::parse_event_t;
    // Keys are checked at the top level and inside the kept entries (skipped ones cost nothing).
    if ((depth <= 1 || !skip_top) && event != E::key) keys.event(depth, event, parsed);
    if (depth == 0) {
      if (event == E::object_start) root_is_object = true;
      return true;
    }
    if (!root_is_object) return true;
    if (depth == 1) {
      if (event == E::key) {
        top = parsed.get<std::string>();
        keys.key(1, top);
        skip_top = !keep_top(top);
        return !skip_top;
      }
      if (event == E::array_start || event == E::object_start) {
        in_array = event == E::array_start;
        index = 0;
      }
      return true;
    }
    if (skip_top) return false;
    if (event == E::key) {
      const std::string key = parsed.get<std::string>();
      if (depth == 2) second = key;
      keys.key(depth, key, 2, [&] {
        return top + (in_array ? "[" + std::to_string(index) + "]" : "." + second);
      });
      if (depth == 2) return true;
    }
    if (depth == 2) {
      if (event == E::value || event == E::object_end || event == E::array_end) {
        const std::string name = in_array ? std::to_string(index++) : second;
        visit(JsonElement{top, name, in_array, parsed});
        return false;  // drop the element: the visitor kept what it needed
      }
      return true;
    }
    return true;
  };
  ChunkedFile chunks(file.get(), path);
  try {
    return json::parse(ChunkIterator(&chunks), ChunkIterator(), callback);
  } catch (const json::parse_error& e) {
    throw_parse_error(path, e);
  }
}

}  // namespace handscs
