// Do a capture's MANO parameters describe the hands its joints do? A capture that gives both (the
// handscs layout's `joints`, InterHand2.6M's joint_3d.json) can tell when its hands are swapped or
// one hand's parameters were copied to the other: the posed rig's joints then lie far from the
// hand's own joints and close to the other hand's, or close only with the other hand's rig.
//
// Typical use (Capture::open, pose_source mano):
//   check_hand_agreement(records, config, rigs, frames, "data");  // throws Error naming hand and file
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "data/capture_config.h"
#include "data/capture_records.h"
#include "hand/rig.h"

namespace handscs {

// Median over sampled frames of the mean distance (mm) between a hand's posed joints and the
// annotated ones (valid joints only); NaN when no frame could be measured.
struct HandAgreement {
  Handedness side = Handedness::right;
  int frames = 0;               // frames measured (those with parameters and enough valid joints)
  double own_mm = 0;            // its parameters on its own rig, against its own joints
  double other_rig_mm = 0;      // its parameters on the other hand's rig, against its own joints
  double other_joints_mm = 0;   // its parameters on its own rig, against the other hand's joints
                                // (NaN where the frames lack the other hand's joints)
};

// Measures hand `side` of `records` posed with `rig` (a rig of that side) and its mirror image, on
// the frames in `selected` (frame numbers; empty: every frame).
HandAgreement measure_hand_agreement(const CaptureRecords& records, Handedness side, const Rig& rig,
                                     bool flat_hand_mean, const std::set<int64_t>& selected = {});

// The hands config.hand selects, each posed with `rigs` (in hand_sides order). Throws Error when
// a hand's parameters fit the other hand (rig or joints) far better than its own joints, or lie
// centimetres from them; logs each hand's figures. Hands without joints are not checked.
// Only the frames the run uses (`selected`) are measured. config_key names the config in messages
// ("data").
void check_hand_agreement(const CaptureRecords& records, const CaptureConfig& config,
                          const std::vector<Rig>& rigs, const std::set<int64_t>& selected,
                          const std::string& config_key);

}  // namespace handscs
