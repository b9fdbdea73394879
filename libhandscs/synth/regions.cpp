#include "synth/regions.h"

#include <nlohmann/json.hpp>

namespace handscs {

std::string regions_legend_json() {
  const nlohmann::json legend = {
      {"regions",
       {{{"name", "crease"},
         {"bit", kRegionCrease},
         {"description", "creases and knuckle skin that change with the flexion of the joint under them"}},
        {{"name", "contact"},
         {"bit", kRegionContact},
         {"description", "tissue flattened where parts touch, and folds between touching parts"}},
        {{"name", "shadow"},
         {"bit", kRegionShadow},
         {"description", "lit skin inside a cast shadow of the key light"}}}},
      {"dilation_px", 1}};
  return legend.dump(2);
}

}  // namespace handscs
