// handscs-bench: the speed-accuracy sweep (docs/BENCHMARKS.md). Trains and scores every point of a
// sweep file at every budget, times the rasterizer over N, and writes results.csv, raster.csv,
// summary.md and the plots; a second call resumes where the first stopped. The command line:
// sweep/bench_command.h.
#include "sweep/bench_command.h"

int main(int argc, char** argv) { return handscs::bench_command(argc, argv); }
