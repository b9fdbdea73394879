// handscs-synth: writes a synthetic capture of the built-in hand in the InterHand2.6M layout, the
// project's own or EasyMocap's. The command line: synth/synth_command.h.
#include "synth/synth_command.h"

int main(int argc, char** argv) { return handscs::synth_command(argc, argv); }
