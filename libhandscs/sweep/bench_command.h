// handscs-bench's command line: the speed-accuracy sweep (sweep/sweep_runner.h), its shards and
// their merge. Returns the process exit status: 0 when every run of the sweep (or shard) is scored.
#pragma once

namespace handscs {

int bench_command(int argc, char** argv);

}  // namespace handscs
