// handscs-train's command line: its options and help text, the run folder checks, data-parallel
// rendezvous, and the training run (train/trainer.h) behind them.
#pragma once

namespace handscs {

// Parses argv as handscs-train and trains; returns the exit status: 0 done, 1 error, 130 stopped
// by SIGINT/SIGTERM (a checkpoint saved), CLI11's statuses for bad options.
int train_command(int argc, char** argv);

}  // namespace handscs
