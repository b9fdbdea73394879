// Typed configuration: each component's config struct lists its fields once in a visit() method,
// and the visitors here read it from JSON (with key-path errors), write it back, and document it.
//
// A config struct looks like:
//   struct RasterConfig {
//     float near_plane = 0.01f;  // metres
//     template <class V> void visit(V& v) {
//       v.field("near_plane", near_plane, "near clipping plane (m)", 1e-6, 10.0);
//     }
//   };
// Supported field types: bool, int, int64_t, float, double, std::string, std::vector of int/float/
// double/std::string, std::vector<std::array<int, 2>> (edge lists); nested structs via v.section().
// Strings limited to a set of names use v.choice(); a choice stored as an enum passes its names
// (ChoiceNames), so code compares enums while files keep the names.
#pragma once

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"

namespace handscs {

using json = nlohmann::json;

// Name of a JSON value's type as users read it in error messages ("number", "string", ...).
std::string json_type_name(const json& value);

// The names of an enum choice as config files write them, in the order --help lists them.
template <class E>
using ChoiceNames = std::vector<std::pair<std::string, E>>;

template <class E>
std::string choice_name(E value, const ChoiceNames<E>& names) {
  for (const auto& [name, option] : names)
    if (option == value) return name;
  throw Error("config: an enum value has no name (programming error)");
}

template <class E>
std::vector<std::string> choice_options(const ChoiceNames<E>& names) {
  std::vector<std::string> options;
  for (const auto& entry : names) options.push_back(entry.first);
  return options;
}

// The value of a name that choice() has already checked against the options.
template <class E>
E choice_value(const std::string& name, const ChoiceNames<E>& names) {
  for (const auto& [option_name, option] : names)
    if (option_name == name) return option;
  throw Error("config: \"" + name + "\" is not an option (programming error)");
}

// Reads a JSON object into a config struct. Errors carry "<source>: <key.path>: <problem>".
class ConfigReader {
 public:
  ConfigReader(const json& object, std::string source, std::string path = "");

  template <class T>
  void field(const char* key, T& value, const char* doc) {
    if (const json* item = take(key)) read_value(*item, value, key_path(key));
  }
  template <class T>
  void field(const char* key, T& value, const char* doc, double lo, double hi) {
    if (const json* item = take(key)) {
      read_value(*item, value, key_path(key));
      check_range(static_cast<double>(value), lo, hi, key_path(key));
    }
  }
  void choice(const char* key, std::string& value, const std::vector<std::string>& options,
              const char* doc);
  template <class E, class = std::enable_if_t<std::is_enum<E>::value>>
  void choice(const char* key, E& value, const ChoiceNames<E>& names, const char* doc) {
    std::string name = choice_name(value, names);
    choice(key, name, choice_options(names), doc);
    value = choice_value(name, names);
  }
  template <class S>
  void section(const char* key, S& sub, const char* doc) {
    if (const json* item = take(key)) {
      if (!item->is_object()) fail(key_path(key), "expected object, got " + json_type_name(*item));
      ConfigReader reader(*item, source_, key_path(key));
      sub.visit(reader);
      reader.finish();
    }
  }
  // Throws if the object holds keys no field asked for (typos must not pass silently).
  void finish() const;

 private:
  const json* take(const char* key);
  std::string key_path(const char* key) const;
  [[noreturn]] void fail(const std::string& path, const std::string& problem) const;
  void check_range(double value, double lo, double hi, const std::string& path) const;

  void read_value(const json& item, bool& out, const std::string& path) const;
  void read_value(const json& item, int& out, const std::string& path) const;
  void read_value(const json& item, int64_t& out, const std::string& path) const;
  void read_value(const json& item, float& out, const std::string& path) const;
  void read_value(const json& item, double& out, const std::string& path) const;
  void read_value(const json& item, std::string& out, const std::string& path) const;
  template <class T>
  void read_value(const json& item, std::vector<T>& out, const std::string& path) const {
    if (!item.is_array()) fail(path, "expected array, got " + json_type_name(item));
    std::vector<T> values(item.size());
    for (size_t i = 0; i < item.size(); ++i)
      read_value(item[i], values[i], path + "[" + std::to_string(i) + "]");
    out = std::move(values);
  }
  template <class T, size_t N>
  void read_value(const json& item, std::array<T, N>& out, const std::string& path) const {
    if (!item.is_array() || item.size() != N)
      fail(path, "expected array of " + std::to_string(N) + ", got " + json_type_name(item) +
                     (item.is_array() ? " of " + std::to_string(item.size()) : ""));
    for (size_t i = 0; i < N; ++i) read_value(item[i], out[i], path + "[" + std::to_string(i) + "]");
  }

  const json& object_;
  std::string source_;
  std::string path_;
  std::set<std::string> seen_;
};

// Writes a config struct to JSON (every field, defaults included).
class ConfigWriter {
 public:
  template <class T>
  void field(const char* key, const T& value, const char* doc, double = 0, double = 0) {
    out[key] = value;
  }
  void choice(const char* key, const std::string& value, const std::vector<std::string>&,
              const char*) {
    out[key] = value;
  }
  template <class E, class = std::enable_if_t<std::is_enum<E>::value>>
  void choice(const char* key, const E& value, const ChoiceNames<E>& names, const char*) {
    out[key] = choice_name(value, names);
  }
  template <class S>
  void section(const char* key, S& sub, const char* doc) {
    ConfigWriter writer;
    sub.visit(writer);
    out[key] = writer.out;
  }
  json out = json::object();
};

// Lists every key with its type, default, allowed range and description (Markdown table rows).
class ConfigDoc {
 public:
  explicit ConfigDoc(std::string path = "") : path_(std::move(path)) {}
  template <class T>
  void field(const char* key, const T& value, const char* doc) {
    add(key, json(value), doc, "");
  }
  template <class T>
  void field(const char* key, const T& value, const char* doc, double lo, double hi) {
    add(key, json(value), doc, "[" + format_number(lo) + ", " + format_number(hi) + "]");
  }
  void choice(const char* key, const std::string& value, const std::vector<std::string>& options,
              const char* doc);
  template <class E, class = std::enable_if_t<std::is_enum<E>::value>>
  void choice(const char* key, const E& value, const ChoiceNames<E>& names, const char* doc) {
    choice(key, choice_name(value, names), choice_options(names), doc);
  }
  template <class S>
  void section(const char* key, S& sub, const char* doc) {
    rows.push_back("| **" + join(key) + "** | section | | | " + doc + " |");
    ConfigDoc child(join(key));
    sub.visit(child);
    rows.insert(rows.end(), child.rows.begin(), child.rows.end());
  }
  std::vector<std::string> rows;

 private:
  std::string join(const char* key) const { return path_.empty() ? key : path_ + "." + key; }
  void add(const char* key, const json& value, const char* doc, const std::string& range);
  static std::string format_number(double x);
  std::string path_;
};

template <class C>
json config_to_json(C& config) {
  ConfigWriter writer;
  config.visit(writer);
  return writer.out;
}

// A key a config no longer has because another key now says the same (a struct lists them in a
// static deprecated_keys()): files and --set may still give it, with a warning when it agrees with
// that key, and an error naming both when it does not.
struct DeprecatedKey {
  const char* old_key;  // e.g. "model.rig"
  const char* key;      // the key that serves for it, e.g. "data.rig"
  const char* why;      // why the two must agree, for the error
};

// Ends the source name of a config merged with --set overrides ("x.json + --set"): its keys from
// x.json were read, and noted, once already.
inline constexpr const char* kWithOverrides = " + --set";

// Ends the source name of a config stored in a checkpoint (meta "config"): a deprecated key there
// was written by an older build, so it is noted, not warned about.
inline constexpr const char* kStoredConfig = " (stored config)";

template <class C, class = void>
struct HasDeprecatedKeys : std::false_type {};
template <class C>
struct HasDeprecatedKeys<C, std::void_t<decltype(C::deprecated_keys())>> : std::true_type {};

// Removes the deprecated keys from `object` (a config as a file writes it; `defaults` gives the
// value of a key it lacks), warning once per source and key. Throws Error when one disagrees.
void drop_deprecated_keys(json& object, const json& defaults, const std::vector<DeprecatedKey>& keys,
                          const std::string& source);

// Gives each deprecated key an override sets a place in `object`, so apply_overrides takes it.
void make_room_for_deprecated_keys(json& object, const std::vector<std::string>& overrides,
                                   const std::vector<DeprecatedKey>& keys);

// Reads `object` into `config` (starting from its defaults); `source` names the origin in errors.
template <class C>
void config_from_json(const json& object, const std::string& source, C& config) {
  if (!object.is_object()) throw Error(source + ": expected a JSON object at the top level, got " +
                                       json_type_name(object));
  if constexpr (HasDeprecatedKeys<C>::value) {
    json current = object;
    C defaults;
    drop_deprecated_keys(current, config_to_json(defaults), C::deprecated_keys(), source);
    ConfigReader reader(current, source);
    config.visit(reader);
    reader.finish();
  } else {
    ConfigReader reader(object, source);
    config.visit(reader);
    reader.finish();
  }
}

template <class C>
std::string config_markdown(C& config) {
  ConfigDoc doc;
  config.visit(doc);
  std::string text = "| key | type | default | range / options | meaning |\n|---|---|---|---|---|\n";
  for (const auto& row : doc.rows) text += row + "\n";
  return text;
}

// Largest JSON file read whole (configs, poses, cameras, rigs, own-capture indexes): far above any
// of them (a MANO-size rig is ~2 MB, a capture index ~1 KB a frame), far below what would strain
// memory.
constexpr size_t kMaxJsonBytes = size_t{256} << 20;

// Parses one JSON file. Errors name the file: a folder, a file over kMaxJsonBytes, bad syntax
// (line and column), numbers beyond a double, a key given twice in one object.
json parse_json_file(const std::string& path);

// Reads a JSON file; a file may name a parent with "extends": "other.json" (relative to itself),
// whose keys it overrides (RFC 7386 merge). Errors name the file, with line/column for bad JSON.
json load_json_file(const std::string& path);

// Applies "a.b.c=value" overrides (value parsed as JSON, else taken as a string). The key must
// already exist in `object` (the defaults), so a typo is an error naming the override.
void apply_overrides(json& object, const std::vector<std::string>& overrides);

// The keys whose values differ between two config objects, as "prefix.key: a -> b" (keys in one
// object only read "(absent)"), in key order. Empty when equal.
std::vector<std::string> json_differences(const json& a, const json& b, const std::string& prefix = "");

// Defaults of C, merged with the file (if given) and the overrides, then validated into C.
template <class C>
C load_config(const std::string& path, const std::vector<std::string>& overrides) {
  C config;
  json merged = config_to_json(config);
  std::string source = "defaults";
  if (!path.empty()) {
    json file = load_json_file(path);
    // Validate the file alone first so its errors name the file, not the merged result.
    C check;
    config_from_json(file, path, check);
    merged.merge_patch(file);
    source = path;
  }
  if constexpr (HasDeprecatedKeys<C>::value)
    make_room_for_deprecated_keys(merged, overrides, C::deprecated_keys());
  apply_overrides(merged, overrides);
  config_from_json(merged, overrides.empty() ? source : source + kWithOverrides, config);
  return config;
}

}  // namespace handscs
