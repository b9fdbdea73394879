// A sweep run stopped half-way (the machine went, the job was pre-empted, Ctrl-C) continues from its
// newest checkpoint when the sweep is run again, instead of training from step 0, but only when the
// run folder was started by the same training command with the same handscs-train binary: a run is
// never finished by other settings or another build than the ones that began it. Resuming is exact
// (the trainer's resume continues the uninterrupted loss curve bit for bit, tests/train), so the
// scores do not depend on where a run stopped; its row leaves the training wall time empty (the
// last attempt's would understate it), gives the last attempt's peak memory, and says in
// resumed_from_step where the last attempt began.
#pragma once

#include <string>
#include <vector>

namespace handscs {

// What makes two attempts one run: the training command with the run folder written as "RUN" (a
// sweep folder may be moved or copied) and the size and modification time of the handscs-train
// binary it calls (argv[0]). JSON text, stored as RUN_DIR/sweep_run.json.
std::string sweep_run_identity(const std::vector<std::string>& train_argv, const std::string& run_dir);

// True when run_dir holds sweep_run.json equal to `identity` and at least one checkpoint file
// (checkpoints/step_*.ckpt, run/checkpoint.h's names); whether one of them loads is the
// trainer's to find out (it falls back past damaged ones, or starts afresh when none is left).
bool sweep_run_resumable(const std::string& run_dir, const std::string& identity);

// Writes RUN_DIR/sweep_run.json (atomically) before a fresh attempt trains.
void record_sweep_run(const std::string& run_dir, const std::string& identity);

// The step a resumed attempt continued from, read from its log ("resumed from FILE at step N",
// the trainer's line); -1 when the log has no such line (the attempt found no checkpoint and
// started afresh).
long long resumed_step_in_log(const std::string& train_log);

}  // namespace handscs
