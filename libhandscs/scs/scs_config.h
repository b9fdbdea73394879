// Configuration of the Structural Coordinate Space: bone basis, virtual-bone generator, descriptor.
// Defaults follow the paper; every ablation of the paper's tables is a switch here.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace handscs {

struct ScsConfig {
  bool enabled = true;  // false: decoders see no structural coordinate ("no SCS" ablation)
  bool static_bones = true;   // include the static (posed skeleton) bones in P
  int virtual_bones = 16;     // M; 0 = no virtual bones
  enum class VirtualSpace { canonical, posed };
  VirtualSpace virtual_space = VirtualSpace::canonical;  // canonical (paper) or posed (ablation)
  bool interpolation = true;  // learn t in [0,1]; false: endpoints at bone midpoints (t = 0.5)
  bool endpoint_offsets = true;  // learn dp, dq; false: no offsets
  // m: radial decay of static bones. 0.03 m, about one finger segment (2-5 cm), keeps each bone's
  // term local as the paper's text asks (docs/SCALING.md#the-defaults-against-the-papers-text).
  double tau = 0.03;
  double max_offset = 0.02;  // m: |dp|, |dq| <= this (tanh-scaled), a fraction of a finger width
  int generator_hidden = 128;  // width of the generator MLP's two hidden layers ("lightweight")
  double norm_eps = 1e-8;  // m: floor of |r| and |b| so Gaussians on joints stay finite
  // Choices the paper leaves open
  // (docs/SCALING.md#the-open-choices-protocol-fixed-before-any-of-its-runs):
  // P built from the Gaussians' means with their gradient (false, as the paper's formulas read
  // literally) or from detached means, so that P's gradient reaches the generator only.
  bool detach_means = false;
  // The decoders' view of P: "none" (P as computed) or "rest": each dimension standardised by its
  // mean and std over the rig's vertices in the zero pose at initialisation, times the
  // embeddings' initial std, so that P and the embeddings enter the decoders at one scale.
  enum class InputNorm { none, rest };
  InputNorm input_norm = InputNorm::none;
  // E_s = (E_MANO \ removed) U cross, on MANO21 joint ids: the wrist's edges to the four fingers
  // replaced by a chain across their bases, from the thumb's to the little finger's.
  std::vector<std::array<int, 2>> removed_edges = {{0, 1}, {0, 4}, {0, 10}, {0, 7}};
  std::vector<std::array<int, 2>> cross_edges = {{13, 1}, {1, 4}, {4, 10}, {10, 7}};

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, "use the structural coordinate P as decoder input");
    v.field("static_bones", static_bones, "include static bones (posed skeleton) in P");
    v.field("virtual_bones", virtual_bones, "number M of virtual bones (0 = none)", 0, 256);
    v.choice("virtual_space", virtual_space,
             {{"canonical", VirtualSpace::canonical}, {"posed", VirtualSpace::posed}},
             "space in which virtual bones and their descriptor live");
    v.field("interpolation", interpolation, "learn interpolation factors t (else t = 0.5)");
    v.field("endpoint_offsets", endpoint_offsets, "learn endpoint offsets dp, dq");
    v.field("tau", tau, "radial decay of static bones (m)", 1e-4, 10.0);
    v.field("max_offset", max_offset, "bound of |dp|, |dq| (m)", 0.0, 1.0);
    v.field("generator_hidden", generator_hidden, "hidden width of the virtual-bone generator", 1,
            4096);
    v.field("norm_eps", norm_eps, "floor of vector norms (m)", 1e-12, 1e-3);
    v.field("detach_means", detach_means,
            "build P from detached Gaussian means (its gradient reaches the generator only)");
    v.choice("input_norm", input_norm, {{"none", InputNorm::none}, {"rest", InputNorm::rest}},
             "decoders' view of P: as computed, or standardised at the zero pose and scaled to "
             "the embeddings' initial std");
    v.field("removed_edges", removed_edges, "MANO21 edges removed from E_MANO");
    v.field("cross_edges", cross_edges, "MANO21 cross-finger edges added to the basis");
  }
};

}  // namespace handscs
