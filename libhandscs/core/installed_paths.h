// Where a program finds the files it needs beside it: its own folder, and the scripts it runs in
// <its folder>/../share/handscs/scripts/ (the install layout; the build folder mirrors it).
#pragma once

#include <string>

namespace handscs {

// Folder of the running executable (/proc/self/exe), so programs find their siblings and scripts.
std::string executable_dir();

// <executable_dir>/../share/handscs: an installed program's configs and scripts (it may not exist).
std::string installed_share_dir();

// Path of the script `name` (e.g. "plot_sweep.py") in <executable_dir>/../share/handscs/scripts/:
// an installed program's own copy, or in the build folder a link into the source tree's scripts/.
// Throws Error naming the path tried when no such file is there.
std::string installed_script(const std::string& name);

}  // namespace handscs
