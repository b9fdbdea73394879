// handscs-synth's command line: a synthetic capture of the built-in hand in the InterHand2.6M
// layout (synth/capture.h) from a named preset, a seed and --set overrides. Returns the exit status.
#pragma once

namespace handscs {

int synth_command(int argc, char** argv);

}  // namespace handscs
