// handscs-synth's command line: a synthetic capture of the built-in hand (synth/capture.h) in the
// InterHand2.6M layout, the project's own or EasyMocap's (--layout), from a named preset, a seed
// and --set overrides. Returns the exit status.
#pragma once

namespace handscs {

int synth_command(int argc, char** argv);

}  // namespace handscs
