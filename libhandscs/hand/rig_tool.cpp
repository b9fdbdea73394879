// handscs-rig actions: see rig_tool.h.
#include "hand/rig_tool.h"

#include <spdlog/spdlog.h>

#include <iostream>

#include "core/error.h"
#include "hand/procedural_hand.h"
#include "hand/rig.h"
#include "hand/rig_info.h"

namespace handscs {

void run_rig_tool(const RigToolOptions& options) {
  require(options.builtin || !options.info.empty(),
          "handscs-rig: nothing to do (use --builtin [--left] --out FILE, or --info RIG)");
  require(!options.left || options.builtin, "handscs-rig: --left needs --builtin");
  require(options.out.empty() || options.builtin, "handscs-rig: --out needs --builtin");
  Rig rig;
  if (options.builtin) {
    rig = make_procedural_hand(options.left ? Handedness::left : Handedness::right);
    if (!options.out.empty()) {
      save_rig(rig, options.out);
      spdlog::info("wrote the built-in {} hand ({} vertices, {} faces) to {}",
                   options.left ? "left" : "right", rig.num_vertices(), rig.faces.size(0),
                   options.out);
    }
  }
  if (!options.info.empty()) rig = load_rig_source(options.info);
  if (!options.obj.empty()) {
    write_rig_obj(rig, options.obj);
    spdlog::info("wrote the template mesh to {}", options.obj);
  }
  if (!options.info.empty()) std::cout << describe_rig(rig);
}

}  // namespace handscs
