// handscs-train: fits a HandSCS avatar to a capture (InterHand2.6M layout) and writes its run folder.
// The command line and the run: train/train_command.h.
#include "train/train_command.h"

int main(int argc, char** argv) { return handscs::train_command(argc, argv); }
