#include "core/config.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <vector>

#include "core/atomic_file.h"
#include "core/installed_paths.h"
#include "core/json_keys.h"

namespace handscs {

std::string json_type_name(const json& value) {
  switch (value.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "number";
    case json::value_t::string: return "string";
    case json::value_t::array: return "array";
    case json::value_t::object: return "object";
    default: return "unknown";
  }
}

ConfigReader::ConfigReader(const json& object, std::string source, std::string path)
    : object_(object), source_(std::move(source)), path_(std::move(path)) {}

const json* ConfigReader::take(const char* key) {
  seen_.insert(key);
  auto it = object_.find(key);
  return it == object_.end() ? nullptr : &*it;
}

std::string ConfigReader::key_path(const char* key) const {
  return path_.empty() ? std::string(key) : path_ + "." + key;
}

void ConfigReader::fail(const std::string& path, const std::string& problem) const {
  throw Error(source_ + ": " + path + ": " + problem);
}

void ConfigReader::check_range(double value, double lo, double hi, const std::string& path) const {
  if (!(value >= lo && value <= hi)) {
    std::ostringstream os;
    os << "value " << value << " out of range [" << lo << ", " << hi << "]";
    fail(path, os.str());
  }
}

void ConfigReader::choice(const char* key, std::string& value,
                          const std::vector<std::string>& options, const char* doc) {
  const json* item = take(key);
  if (!item) return;
  read_value(*item, value, key_path(key));
  for (const auto& option : options)
    if (option == value) return;
  std::string known;
  for (const auto& option : options) known += (known.empty() ? "" : ", ") + option;
  fail(key_path(key), "unknown value \"" + value + "\" (known: " + known + ")");
}

void ConfigReader::finish() const {
  for (auto it = object_.begin(); it != object_.end(); ++it)
    if (!seen_.count(it.key())) fail(key_path(it.key().c_str()), "unknown key");
}

void ConfigReader::read_value(const json& item, bool& out, const std::string& path) const {
  if (!item.is_boolean()) fail(path, "expected boolean, got " + json_type_name(item));
  out = item.get<bool>();
}

void ConfigReader::read_value(const json& item, int64_t& out, const std::string& path) const {
  if (!item.is_number()) fail(path, "expected integer, got " + json_type_name(item));
  if (!item.is_number_integer()) {
    double x = item.get<double>();
    if (x != std::floor(x) || std::fabs(x) > 9.0e15)
      fail(path, "expected integer, got " + item.dump());
    out = static_cast<int64_t>(x);
    return;
  }
  out = item.get<int64_t>();
}

void ConfigReader::read_value(const json& item, int& out, const std::string& path) const {
  int64_t wide = 0;
  read_value(item, wide, path);
  if (wide < std::numeric_limits<int>::min() || wide > std::numeric_limits<int>::max())
    fail(path, "integer " + std::to_string(wide) + " does not fit in 32 bits");
  out = static_cast<int>(wide);
}

void ConfigReader::read_value(const json& item, double& out, const std::string& path) const {
  if (!item.is_number()) fail(path, "expected number, got " + json_type_name(item));
  out = item.get<double>();
  if (!std::isfinite(out)) fail(path, "expected a finite number");
}

void ConfigReader::read_value(const json& item, float& out, const std::string& path) const {
  double wide = 0;
  read_value(item, wide, path);
  out = static_cast<float>(wide);
}

void ConfigReader::read_value(const json& item, std::string& out, const std::string& path) const {
  if (!item.is_string()) fail(path, "expected string, got " + json_type_name(item));
  out = item.get<std::string>();
}

void ConfigDoc::choice(const char* key, const std::string& value,
                       const std::vector<std::string>& options, const char* doc) {
  std::string known;
  for (const auto& option : options) known += (known.empty() ? "" : ", ") + option;
  add(key, json(value), doc, known);
}

void ConfigDoc::add(const char* key, const json& value, const char* doc, const std::string& range) {
  std::string shown = value.dump();
  if (shown.size() > 60) shown = shown.substr(0, 57) + "...";
  std::string escaped;
  for (char c : shown) escaped += (c == '|') ? std::string("\\|") : std::string(1, c);
  rows.push_back("| `" + join(key) + "` | " + json_type_name(value) + " | `" + escaped + "` | " +
                 range + " | " + doc + " |");
}

std::string ConfigDoc::format_number(double x) {
  std::ostringstream os;
  os << x;
  return os.str();
}


json parse_json_file(const std::string& path) {
  ReadableFile in(path, "JSON file");
  std::string text;
  if (!in.append_rest(text, kMaxJsonBytes))
    throw Error(path + ": larger than " + std::to_string(kMaxJsonBytes >> 20) +
                " MB, the limit of a JSON file read whole (configs, poses, cameras, rigs, "
                "capture indexes)");
  try {
    JsonKeyGuard keys(path);
    return json::parse(text, [&keys](int depth, json::parse_event_t event, json& parsed) {
      keys.event(depth, event, parsed);
      return true;
    });
  } catch (const json::parse_error& e) {
    // Report the line and column of the byte offset nlohmann gives.
    size_t line = 1, column = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    throw Error(path + ": malformed JSON at line " + std::to_string(line) + ", column " +
                std::to_string(column) + " (" + std::string(e.what()) + ")");
  } catch (const json::out_of_range& e) {  // 1e999: a number beyond a double
    throw Error(path + ": a number is out of range of a double (" + std::string(e.what()) + ")");
  } catch (const json::exception& e) {
    throw Error(path + ": malformed JSON (" + std::string(e.what()) + ")");
  }
}

namespace {

json load_json_file_depth(const std::string& path, int depth) {
  if (depth > 8) throw Error(path + ": \"extends\" chain deeper than 8 files (a cycle?)");
  json object = parse_json_file(path);
  if (!object.is_object())
    throw Error(path + ": expected a JSON object at the top level, got " + json_type_name(object));
  auto it = object.find("extends");
  if (it == object.end()) return object;
  if (!it->is_string())
    throw Error(path + ": extends: expected string, got " + json_type_name(*it));
  std::filesystem::path parent =
      std::filesystem::path(path).parent_path() / it->get<std::string>();
  object.erase("extends");
  json base = load_json_file_depth(parent.string(), depth + 1);
  base.merge_patch(object);
  return base;
}

}  // namespace

json load_json_file(const std::string& path) {
  // An installed program run from another folder with the README's `--config configs/base.json`:
  // "cannot open file" alone does not say where the installed configs are.
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::path(path).is_relative() && !fs::exists(fs::symlink_status(path, ec))) {
    const fs::path installed =
        fs::weakly_canonical(fs::path(installed_share_dir()) / path, ec);
    if (!ec && fs::is_regular_file(installed, ec))
      throw Error(path + ": no such file in " + fs::current_path(ec).string() + "; the installed " +
                  "one is " + installed.string() + " (give that path)");
  }
  return load_json_file_depth(path, 0);
}

namespace {

// The value at a dotted key path ("model.rig"), or nullptr.
json* config_value_at(json& object, const std::string& path) {
  json* node = &object;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(part)) return nullptr;
    node = &(*node)[part];
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

}  // namespace

void drop_deprecated_keys(json& object, const json& defaults, const std::vector<DeprecatedKey>& keys,
                          const std::string& source) {
  static std::set<std::string> warned;  // one notice per origin and key in a process
  const auto ends_with = [](const std::string& text, const std::string& end) {
    return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
  };
  const std::string with_overrides = kWithOverrides;
  const std::string origin =
      ends_with(source, with_overrides) ? source.substr(0, source.size() - with_overrides.size()) : source;
  const bool stored = ends_with(origin, kStoredConfig);
  json lookup = defaults;
  lookup.merge_patch(object);
  for (const auto& k : keys) {
    const std::string old_key = k.old_key;
    const json* old_value = config_value_at(object, old_key);
    if (old_value == nullptr) continue;
    const json* value = config_value_at(lookup, k.key);
    const json current = value ? *value : json();
    if (*old_value != current)
      throw Error(source + ": " + k.key + " (" + current.dump() + ") and " + old_key + " (" +
                  old_value->dump() + ") must agree: " + k.why + " (" + old_key +
                  " is deprecated: set " + k.key + " alone)");
    if (warned.insert(origin + "|" + old_key).second) {
      if (stored)  // a checkpoint of an older build: nothing the user can or needs to edit
        spdlog::info("{}: written with {}, read as {}", origin, old_key, k.key);
      else
        spdlog::warn("{}: {} is deprecated ({} serves for it): drop it", source, old_key, k.key);
    }
    const size_t dot = old_key.rfind('.');
    json* parent = dot == std::string::npos ? &object : config_value_at(object, old_key.substr(0, dot));
    parent->erase(old_key.substr(dot == std::string::npos ? 0 : dot + 1));
  }
}

void make_room_for_deprecated_keys(json& object, const std::vector<std::string>& overrides,
                                   const std::vector<DeprecatedKey>& keys) {
  for (const auto& text : overrides)
    for (const auto& k : keys) {
      const std::string old_key = k.old_key;
      if (text.compare(0, old_key.size() + 1, old_key + "=") != 0 || config_value_at(object, old_key)) continue;
      const size_t dot = old_key.rfind('.');
      json* parent = dot == std::string::npos ? &object : config_value_at(object, old_key.substr(0, dot));
      if (parent != nullptr && parent->is_object()) (*parent)[old_key.substr(dot == std::string::npos ? 0 : dot + 1)] = nullptr;
    }
}

void apply_overrides(json& object, const std::vector<std::string>& overrides) {
  for (const auto& text : overrides) {
    const size_t eq = text.find('=');
    if (eq == std::string::npos || eq == 0)
      throw Error("--set " + text + ": expected key.path=value");
    const std::string key = text.substr(0, eq);
    const std::string raw = text.substr(eq + 1);
    json value;
    try {
      value = json::parse(raw);
    } catch (const json::parse_error&) {
      value = raw;  // bare words are strings: --set data.split=novel_view
    } catch (const json::out_of_range&) {  // a number beyond a double's range, e.g. 1e999
      throw Error("--set " + text + ": " + raw + " is beyond the range of a number (about 1.8e308)");
    }
    json* node = &object;
    std::string walked;
    size_t start = 0;
    while (true) {
      const size_t dot = key.find('.', start);
      const std::string part = key.substr(start, dot == std::string::npos ? std::string::npos
                                                                          : dot - start);
      walked += (walked.empty() ? "" : ".") + part;
      if (!node->is_object() || !node->contains(part))
        throw Error("--set " + text + ": unknown key " + walked);
      node = &(*node)[part];
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    // A section replaced by a value would be reported later against a valid key of another
    // --set: refuse it here, where the cause is.
    if (node->is_object()) {
      const std::string first = node->empty() ? "KEY" : node->begin().key();
      throw Error("--set " + text + ": " + walked + " is a section, not a value; set its keys, e.g. " +
                  walked + "." + first + "=...");
    }
    *node = value;
  }
}

std::vector<std::string> json_differences(const json& a, const json& b, const std::string& prefix) {
  std::vector<std::string> out;
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (const auto& item : a.items()) keys.insert(item.key());
    for (const auto& item : b.items()) keys.insert(item.key());
    for (const auto& key : keys) {
      const std::string path = prefix.empty() ? key : prefix + "." + key;
      const auto in_a = a.find(key), in_b = b.find(key);
      if (in_a == a.end() || in_b == b.end()) {
        out.push_back(path + ": " + (in_a == a.end() ? "(absent)" : in_a->dump()) + " -> " +
                      (in_b == b.end() ? "(absent)" : in_b->dump()));
        continue;
      }
      for (auto& line : json_differences(*in_a, *in_b, path)) out.push_back(std::move(line));
    }
  } else if (a != b) {
    out.push_back((prefix.empty() ? "(value)" : prefix) + ": " + a.dump() + " -> " + b.dump());
  }
  return out;
}

}  // namespace handscs
