// Checked, streaming access to JSON data files (InterHand2.6M's annotations, the project's
// capture.json): every failure names the file and the key path
// ("annotations/test/InterHand2.6M_test_camera.json: 3.campos.400026: expected array of 3").
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace handscs {

// A JSON value together with where it came from (file and key path), for error messages.
class JsonView {
 public:
  JsonView(const nlohmann::json& value, const std::string& file, std::string path)
      : value_(&value), file_(&file), path_(std::move(path)) {}

  const nlohmann::json& raw() const { return *value_; }
  const std::string& path() const { return path_; }
  bool is_null() const { return value_->is_null(); }
  bool has(const char* key) const { return value_->is_object() && value_->contains(key); }

  // Object member; throws "<file>: <path>: missing key \"key\"" (or "expected object, got ...").
  JsonView at(const std::string& key) const;
  // Array element; the caller checked the size with array(n) or size().
  JsonView at(size_t index) const;
  // Number of elements of an array; throws "expected array, got ..." for other types.
  size_t size() const;
  // Checks that this is an array of exactly n elements and returns n.
  size_t array(size_t n) const;
  void require_object() const;
  // Checks that this is an object whose keys are all among `known`; throws naming the first other
  // key and listing the known ones (a misspelt optional key would otherwise be ignored).
  void require_known_keys(const std::vector<std::string>& known) const;

  double number() const;       // finite number
  int64_t integer() const;     // integer (or a number with an integral value)
  std::string string() const;  // string
  bool flag() const;           // true/false or a number 0/1 (InterHand writes both)

  // Flat array of n numbers into out[0..n).
  void numbers(double* out, size_t n) const;
  // rows x cols nested array (row-major) into out[0..rows*cols).
  void matrix(double* out, size_t rows, size_t cols) const;
  // n flags, each either a scalar or a one-element array ([1] / [true], as joint_valid is stored).
  void flags(uint8_t* out, size_t n) const;

  [[noreturn]] void fail(const std::string& problem) const;

 private:
  std::string child(const std::string& key) const;
  const nlohmann::json* value_;
  const std::string* file_;
  std::string path_;
};

// Name of a JSON value's type as users read it ("number", "string", "array", ...).
std::string json_kind(const nlohmann::json& value);

// What stream_json_elements hands to its visitor: one element at depth 2 of the document, i.e.
// `top[second]` where `top` is a top-level key and `second` an object key or an array index.
struct JsonElement {
  const std::string& top;     // top-level key ("images", or a capture id "3")
  const std::string& second;  // object key (frame index) or array index as text
  bool in_array;              // true when `second` is an array index
  const nlohmann::json& value;
};

// Parses `path` with a streaming callback: each depth-2 element goes to `visit` and is then
// dropped, so a multi-GB annotation file never exists as one DOM. `keep_top(key)` == false skips a
// whole top-level entry (e.g. other captures). Returns the skeleton that remains (top-level keys
// with emptied containers, and any top-level scalars) for structure checks. Throws Error naming the
// file (with line and column) for malformed JSON, and for a file that cannot be opened.
nlohmann::json stream_json_elements(const std::string& path,
                                    const std::function<bool(const std::string&)>& keep_top,
                                    const std::function<void(const JsonElement&)>& visit);

}  // namespace handscs
