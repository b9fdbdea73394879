// The ways a realistic synthetic capture differs from the avatar's own model (issue "A synthetic
// capture that HandSCS has to earn"): each effect has a switch and documented parameters, so it can
// be turned off alone (handscs-synth --set effects.<name>=false) and its effect measured.
#pragma once

namespace handscs {

struct SynthEffects {
  // 1. Non-rigid tissue the rig does not have, in the ground truth only (synth/tissue.h).
  bool tissue = false;
  // Knuckle prominence on full (90 degree) flexion: the metacarpal/phalanx head pushes the
  // stretched dorsal skin out by a few millimetres (hand anatomy; skin over the MCP is ~1.5 mm).
  double knuckle_bulge_mm = 2.0;
  // Palmar soft tissue compressed on the flexed side, and the crease fold at the joint line.
  double flexed_side_mm = 1.5, crease_fold_mm = 1.0;
  // Palm cupping (depth at the palm centre) with finger flexion and thenar bulge with opposition.
  double palm_cup_mm = 2.5, thenar_bulge_mm = 2.0;
  // Fingertip/finger pulp flattening where two parts touch: soft tissue yields up to this depth
  // (finger pulp compresses 1-3 mm under light contact).
  double contact_radius_mm = 5.0, contact_max_mm = 2.0;

  // 2. Imperfect annotations: MANO fit error, smooth in time (synth/fit_error.h). NeuralAnnot's
  // fits disagree with triangulated joints by millimetres; a few degrees per joint is their order.
  bool fit_error = false;
  double fit_pose_deg = 3.0;     // RMS per joint axis-angle component
  double fit_global_deg = 1.5;   // RMS of the global orientation error
  double fit_trans_mm = 2.0;     // RMS per translation component
  // Triangulation error of InterHand2.6M-layout joint_3d.json (what data.pose_source = joints fits):
  // Gaussian, independent per joint and coordinate, RMS per coordinate (mm); 0 writes the rendered
  // joints exactly. Independent of fit_error.
  double joint_noise_mm = 0.0;
  double fit_shape = 0.15;       // RMS per shape coefficient (a fit's shape varies per frame)
  double fit_period_frames = 12; // typical period of the error's variation (5 fps frames)

  // 3. Skin whose creases deepen, widen and darken with the flexion of the joint under them, and
  // lighter (blanched) stretched skin over flexed knuckles (synth/skin.h).
  bool flexion_skin = false;

  // 4. Light that depends on the posed shape: soft cast shadows of the world-fixed key light (an
  // area light of the given angular radius), computed on the posed geometry (synth/shadows.h).
  bool cast_shadows = false;
  double light_radius_deg = 4.0;  // studio softbox at ~1.5 m: a few degrees
  int light_samples = 12;         // rays per vertex towards the area light
  // Ambient occlusion of folds and touching fingers (the older captures already have it).
  bool ambient_occlusion = true;

  // 5. Independent finger motion from a vocabulary of gestures; the held-out tail of the capture
  // contains gestures never seen in training (synth/gestures.h). Off: the one-phase range of motion.
  bool gestures = false;

  // 6. What real frames contain besides the hand: the forearm (not in the MANO masks), a dark
  // background with sensor noise and vignetting, per-camera gain and white balance, and monochrome
  // cameras as InterHand2.6M has (synth/forearm.h, synth/camera_response.h).
  bool forearm = false;
  bool camera_response = false;  // gain, white balance, sensor noise on every pixel, vignetting
  double gain_spread = 0.12;     // per-camera exposure gain uniform in [1 - s, 1 + s]
  double white_balance_spread = 0.05;  // per-camera R and B gains, N(1, s^2) relative to G
  double read_noise = 1.2;       // sensor read noise (8-bit levels, RMS)
  double shot_noise = 0.02;      // shot noise variance per level of signal (levels)
  int monochrome_every = 0;      // every k-th camera is monochrome (0 = none)

  // 7. Region masks (creases, contact, cast shadows) beside the capture in regions/.
  bool region_masks = false;

  template <class V>
  void visit(V& v) {
    v.field("tissue", tissue, "1: non-rigid tissue (knuckles, flexed side, palm, contact)");
    v.field("knuckle_bulge_mm", knuckle_bulge_mm, "knuckle bulge at 90 degrees flexion (mm)", 0, 20);
    v.field("flexed_side_mm", flexed_side_mm, "palmar compression at 90 degrees (mm)", 0, 20);
    v.field("crease_fold_mm", crease_fold_mm, "crease fold depth at 90 degrees (mm)", 0, 20);
    v.field("palm_cup_mm", palm_cup_mm, "palm cupping depth at full flexion (mm)", 0, 20);
    v.field("thenar_bulge_mm", thenar_bulge_mm, "thenar bulge at full opposition (mm)", 0, 20);
    v.field("contact_radius_mm", contact_radius_mm, "distance at which tissue yields (mm)", 0, 50);
    v.field("contact_max_mm", contact_max_mm, "largest contact flattening (mm)", 0, 20);
    v.field("fit_error", fit_error, "2: MANO fit error in the annotations");
    v.field("fit_pose_deg", fit_pose_deg, "RMS finger pose error per component (deg)", 0, 90);
    v.field("fit_global_deg", fit_global_deg, "RMS global orientation error (deg)", 0, 90);
    v.field("fit_trans_mm", fit_trans_mm, "RMS translation error per component (mm)", 0, 1000);
    v.field("joint_noise_mm", joint_noise_mm, "RMS noise per coordinate of joint_3d.json's joints (mm)", 0, 1000);
    v.field("fit_shape", fit_shape, "RMS shape coefficient error", 0, 10);
    v.field("fit_period_frames", fit_period_frames, "typical period of the error (frames)", 1,
            1e6);
    v.field("flexion_skin", flexion_skin, "3: creases that deepen with flexion");
    v.field("cast_shadows", cast_shadows, "4: soft cast shadows of the key light");
    v.field("light_radius_deg", light_radius_deg, "angular radius of the key light (deg)", 0, 45);
    v.field("light_samples", light_samples, "shadow rays per vertex", 1, 256);
    v.field("ambient_occlusion", ambient_occlusion, "fold and contact ambient occlusion");
    v.field("gestures", gestures, "5: independent fingers from a gesture vocabulary");
    v.field("forearm", forearm, "6: the forearm continues out of the frame");
    v.field("camera_response", camera_response, "6: gain, white balance, sensor noise, vignetting");
    v.field("gain_spread", gain_spread, "per-camera gain spread", 0, 0.9);
    v.field("white_balance_spread", white_balance_spread, "per-camera R/B gain RMS", 0, 0.5);
    v.field("read_noise", read_noise, "read noise (levels RMS)", 0, 50);
    v.field("shot_noise", shot_noise, "shot noise variance per level", 0, 10);
    v.field("monochrome_every", monochrome_every, "every k-th camera monochrome (0 = none)", 0,
            1000);
    v.field("region_masks", region_masks, "7: write regions/ masks (crease, contact, shadow)");
  }
};

}  // namespace handscs
