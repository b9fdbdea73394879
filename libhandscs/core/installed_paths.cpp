#include "core/installed_paths.h"

#include <filesystem>

#include "core/error.h"

namespace handscs {

std::string executable_dir() {
  std::error_code error;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) throw Error("/proc/self/exe: cannot resolve the running executable");
  return exe.parent_path().string();
}

std::string installed_share_dir() {
  return (std::filesystem::path(executable_dir()).parent_path() / "share" / "handscs").string();
}

std::string installed_script(const std::string& name) {
  const auto path = std::filesystem::path(installed_share_dir()) / "scripts" / name;
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw Error(name + " not found: tried " + path.string() + " (installed programs keep it in " +
                "<prefix>/share/handscs/scripts/; a build folder links it there when configured)");
  return path.string();
}

}  // namespace handscs
