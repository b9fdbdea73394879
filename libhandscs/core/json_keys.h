// A key given twice in one JSON object is an error: nlohmann keeps the last one silently, so
// {"iterations": 400, ..., "iterations": 4} would run 4 steps without a word. Fed from a parser
// callback (whole-file parses and the streamed annotation readers alike).
#pragma once

#include <string>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"

namespace handscs {

// Keys of the objects being read, per parse depth (the callback's `depth`: 1 = the root object's
// keys). The parser sends no end event for a value a callback drops, so a depth's keys are reset
// when an object starts there, never at its end.
class JsonKeyGuard {
 public:
  explicit JsonKeyGuard(std::string path) : path_(std::move(path)) {}

  // Every event of a parse (or of the parts being kept), as the callback gets it.
  void event(int depth, nlohmann::json::parse_event_t event, const nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    if (event == E::object_start) level(depth + 1).keys.clear();
    if (event == E::array_start) level(depth + 1).name = "[]";
    if (event == E::key) key(depth, parsed.get_ref<const std::string&>());
  }

  // A key at `depth`. Throws Error "<path>: <where>: key given twice ..." where `where` is
  // prefix() for depths up to prefix_depth and the keys seen below it ("poses[].pose"); prefix is
  // called only for the error.
  template <class Prefix>
  void key(int depth, const std::string& name, int prefix_depth, const Prefix& prefix) {
    Level& current = level(depth);
    current.name = name;
    if (current.keys.insert(name).second) return;
    std::string where = prefix();
    for (int d = prefix_depth + 1; d <= depth; ++d) {
      const std::string& part = levels_[d].name;
      where += part == "[]" ? part : (where.empty() ? "" : ".") + part;
    }
    throw Error(path_ + ": " + where + ": key given twice (remove one; JSON readers would keep the last)");
  }
  void key(int depth, const std::string& name) {
    key(depth, name, 0, [] { return std::string(); });
  }

 private:
  struct Level {
    std::unordered_set<std::string> keys;
    std::string name;  // the member (or "[]" for an array element) being read at this depth
  };
  Level& level(int depth) {
    if (levels_.size() <= static_cast<size_t>(depth)) levels_.resize(depth + 1);
    return levels_[depth];
  }
  std::string path_;
  std::vector<Level> levels_;
};

}  // namespace handscs
