#include "data/cache_files.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "core/hash.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

constexpr char kBesideFolder[] = ".handscs-cache";

std::string hex16(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(value));
  return text;
}

// The user's cache folder for caches of `kind`, "" when neither variable is set.
std::string user_cache_folder(const std::string& kind) {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return (fs::path(xdg) / "handscs" / kind).string();
  if (const char* home = std::getenv("HOME"); home && *home)
    return (fs::path(home) / ".cache" / "handscs" / kind).string();
  return "";
}

}  // namespace

std::vector<std::string> cache_files_for(const std::string& setting, const std::string& source,
                                         const std::string& name, const std::string& kind) {
  if (setting == "off") return {};
  const fs::path path(source);
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) canonical = path;
  const std::string key = canonical.string();
  const std::string shared_name = hex16(fnv1a64(key.data(), key.size())) + "-" + name;
  if (setting != "auto") return {(fs::path(setting) / shared_name).string()};
  std::vector<std::string> files{(canonical.parent_path() / kBesideFolder / name).string()};
  const std::string user = user_cache_folder(kind);
  if (!user.empty()) files.push_back((fs::path(user) / shared_name).string());
  return files;
}

}  // namespace handscs
