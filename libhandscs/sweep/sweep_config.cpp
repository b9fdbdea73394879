#include "sweep/sweep_config.h"

#include <filesystem>
#include <regex>
#include <set>

#include "core/config.h"
#include "core/error.h"

namespace handscs {

namespace {


// Typed access to one object of the sweep file, with the key path in every error.
class Reader {
 public:
  Reader(const json& object, std::string file, std::string prefix)
      : object_(object), file_(std::move(file)), prefix_(std::move(prefix)) {
    if (!object_.is_object()) fail("", "expected an object, got " + json_type_name(object_));
    for (const auto& item : object_.items()) unknown_.insert(item.key());
  }
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    const std::string path = prefix_.empty() ? key : (key.empty() ? prefix_ : prefix_ + "." + key);
    throw Error(file_ + ": " + (path.empty() ? "" : path + ": ") + problem);
  }
  const json* find(const std::string& key) {
    unknown_.erase(key);
    auto it = object_.find(key);
    return it == object_.end() ? nullptr : &*it;
  }
  int integer(const std::string& key, int fallback, int lo, int hi) {
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_number_integer()) fail(key, "expected integer, got " + json_type_name(*v));
    const auto x = v->get<int64_t>();
    if (x < lo || x > hi)
      fail(key, std::to_string(x) + " is outside [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "]");
    return static_cast<int>(x);
  }
  std::string text(const std::string& key, const std::string& fallback, bool required = false) {
    const json* v = find(key);
    if (!v) {
      if (required) fail(key, "missing (required)");
      return fallback;
    }
    if (!v->is_string()) fail(key, "expected string, got " + json_type_name(*v));
    return v->get<std::string>();
  }
  std::vector<int> integers(const std::string& key, std::vector<int> fallback, int lo, int hi) {
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_array()) fail(key, "expected array, got " + json_type_name(*v));
    std::vector<int> out;
    for (size_t i = 0; i < v->size(); ++i) {
      const json& item = (*v)[i];
      const std::string at = key + "[" + std::to_string(i) + "]";
      if (!item.is_number_integer()) fail(at, "expected integer, got " + json_type_name(item));
      const auto x = item.get<int64_t>();
      if (x < lo || x > hi)
        fail(at, std::to_string(x) + " is outside [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
      out.push_back(static_cast<int>(x));
    }
    return out;
  }
  std::vector<std::string> strings(const std::string& key) {
    const json* v = find(key);
    if (!v) return {};
    if (!v->is_array()) fail(key, "expected array, got " + json_type_name(*v));
    std::vector<std::string> out;
    for (size_t i = 0; i < v->size(); ++i) {
      const json& item = (*v)[i];
      if (!item.is_string())
        fail(key + "[" + std::to_string(i) + "]", "expected string, got " + json_type_name(item));
      out.push_back(item.get<std::string>());
    }
    return out;
  }
  // Every key of the object must have been asked for: a typo is an error, not a silent default.
  void finish() const {
    if (!unknown_.empty()) fail(*unknown_.begin(), "unknown key");
  }

 private:
  const json& object_;
  std::string file_, prefix_;
  std::set<std::string> unknown_;
};

constexpr int kMaxIterations = 10000000;
constexpr int kMaxThreads = 1024;

}  // namespace

SweepConfig load_sweep_config(const std::string& path) {
  const json file = load_json_file(path);
  SweepConfig c;
  c.path = path;
  Reader top(file, path, "");
  const std::string run_config = top.text("run_config", "", true);
  const auto dir = std::filesystem::path(path).parent_path();
  c.run_config = std::filesystem::absolute(dir / run_config).lexically_normal().string();
  c.capture_preset = top.text("capture_preset", c.capture_preset);
  c.budgets = top.integers("budgets", {}, 1, kMaxIterations);
  if (c.budgets.empty()) top.fail("budgets", "needs at least one training budget");
  c.eval_images = top.integer("eval_images", c.eval_images, 0, 1000000);
  c.threads = top.integer("threads", c.threads, 0, kMaxThreads);
  // Settings every point shares (e.g. a default changed since the sweep was measured, pinned so it
  // reproduces as recorded); a point's own settings come after them and win.
  const std::vector<std::string> shared_set = top.strings("set");

  const json* points = top.find("points");
  if (!points || !points->is_array() || points->empty())
    top.fail("points", "expected a non-empty array of {\"name\", \"set\"} objects");
  const std::regex name_pattern("[A-Za-z0-9_.-]+");
  std::set<std::string> names;
  for (size_t i = 0; i < points->size(); ++i) {
    Reader r((*points)[i], path, "points[" + std::to_string(i) + "]");
    SweepPoint p;
    p.name = r.text("name", "", true);
    if (!std::regex_match(p.name, name_pattern))
      r.fail("name", "\"" + p.name + "\" must match [A-Za-z0-9_.-]+ (it names a folder)");
    if (!names.insert(p.name).second) r.fail("name", "\"" + p.name + "\" is used twice");
    p.set = shared_set;
    for (auto& s : r.strings("set")) p.set.push_back(std::move(s));
    p.threads = r.integer("threads", 0, 0, kMaxThreads);
    p.budgets = r.integers("budgets", {}, 1, kMaxIterations);
    r.finish();
    c.points.push_back(std::move(p));
  }

  if (const json* raster = top.find("raster")) {
    Reader r(*raster, path, "raster");
    c.raster.gaussians = r.integers("gaussians", {}, 1, 100000000);
    c.raster.threads = r.integers("threads", c.raster.threads, 1, kMaxThreads);
    c.raster.repeats = r.integer("repeats", c.raster.repeats, 1, 100000);
    r.finish();
  }
  top.finish();
  return c;
}

}  // namespace handscs
