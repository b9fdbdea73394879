// A sweep's results.csv: its columns, one row per (point, budget), and reading it back, also as an
// earlier version wrote it, so a sweep resumes and shards merge across that version change.
#pragma once

#include <string>
#include <vector>

#include "core/csv_table.h"

namespace handscs {

// The columns of results.csv, in order.
const std::vector<std::string>& result_columns();

// Reads path's results table. A file of the version before resumed_from_step existed (the same
// columns without it) is read with that column empty; any other header is an error naming the
// file.
CsvTable read_results(const std::string& path);

}  // namespace handscs
