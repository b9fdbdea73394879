// The work behind `handscs-rig`: write the built-in hand as a rig file, print a rig's summary,
// export a rig's template mesh as OBJ.
#pragma once

#include <string>

namespace handscs {

struct RigToolOptions {
  bool builtin = false;  // use the built-in procedural hand as the rig
  bool left = false;     // with builtin: the left hand
  std::string info;      // rig source to describe (a built-in name or a rig file: load_rig_source)
  std::string out;       // rig file to write (with builtin)
  std::string obj;       // OBJ file to write (template mesh of the chosen rig)
};

// Runs the requested actions in the order: write rig file, write OBJ, print info (to stdout).
// Throws Error when nothing was requested or a source cannot be read.
void run_rig_tool(const RigToolOptions& options);

}  // namespace handscs
