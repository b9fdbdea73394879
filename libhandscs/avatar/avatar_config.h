// Configuration of the HandSCS avatar: rig, Gaussian initialisation, embeddings, decoders, SCS.
// Defaults follow the paper; each paper ablation is a switch (here or in ScsConfig).
#pragma once

#include <cstdint>
#include <string>

#include "scs/scs_config.h"

namespace handscs {

struct AvatarConfig {
  // The rig and its pose convention. Not keys of the model section: a run config reads them from
  // data.rig and data.flat_hand_mean (run/run_config.h), as masks and avatar are posed alike.
  std::string rig = "builtin";  // a rig source: "builtin", "builtin+fingers", ... or a rig file (load_rig_source, docs/RIG_FORMAT.md)
  bool flat_hand_mean = false;  // false: poses are relative to the rig's hands_mean (InterHand2.6M)
  bool embeddings = true;       // per-Gaussian embeddings e_g, e_a as decoder inputs
  int embedding_dim = 32;       // d of e_g and e_a (paper)
  double embedding_init_std = 1e-2;  // N(0, 1e-2): small so decoders start from structure alone
  int decoder_hidden = 256;     // width of the two hidden layers of each decoder (paper)
  // Arithmetic of the decoder matmuls when the avatar is in float: "bf16" runs them in bfloat16
  // with float accumulation and float master weights (faster where the CPU has AVX512-BF16;
  // docs/BENCHMARKS.md#model-forward-and-backward), "float" keeps float; "auto" picks bf16 only where
  // the CPU has it natively.
  // A double avatar (gradient checks) always stays in double.
  enum class DecoderPrecision { automatic, float32, bf16 };
  DecoderPrecision decoder_precision = DecoderPrecision::automatic;
  double opacity_init_min = 0.5;  // random initial opacity U(min, max): opaque enough to cover skin
  double opacity_init_max = 0.95;
  double scale_init_factor = 1.0;  // initial isotropic scale = factor x mean 3-NN vertex distance
  int64_t seed = 0;             // initialisation seed (Gaussians, embeddings, networks)
  // data.hand both: one set of decoders for the two hands (each keeps its Gaussians, embeddings and
  // virtual bones). Off: each hand has its own, as a one-hand avatar (docs/TRAINING.md#two-hands).
  bool shared_decoders = false;
  ScsConfig scs;

  template <class V>
  void visit(V& v) {
    v.field("embeddings", embeddings, "use per-Gaussian embeddings e_g, e_a");
    v.field("embedding_dim", embedding_dim, "embedding size d", 1, 1024);
    v.field("embedding_init_std", embedding_init_std, "std of the embeddings' initial values", 0.0,
            10.0);
    v.field("decoder_hidden", decoder_hidden, "hidden width of the decoder MLPs", 1, 4096);
    v.choice("decoder_precision", decoder_precision,
             {{"auto", DecoderPrecision::automatic}, {"float", DecoderPrecision::float32},
              {"bf16", DecoderPrecision::bf16}},
             "decoder matmul arithmetic for a float avatar: auto = bf16 where the CPU has AVX512-BF16");
    v.field("opacity_init_min", opacity_init_min, "lower bound of random initial opacity", 1e-4,
            0.9999);
    v.field("opacity_init_max", opacity_init_max, "upper bound of random initial opacity", 1e-4,
            0.9999);
    v.field("scale_init_factor", scale_init_factor, "initial scale / mean 3-NN distance", 1e-3,
            100.0);
    v.field("seed", seed, "initialisation seed", 0, 9.0e15);
    v.field("shared_decoders", shared_decoders,
            "data.hand both: the two hands share one set of decoders (own Gaussians, embeddings, bones)");
    v.section("scs", scs, "Structural Coordinate Space");
  }
};

}  // namespace handscs
