// A small CSV table (header + rows of text cells): sweep results read back to resume a sweep, and
// the one CSV quoting rule (csv_cell) the evaluation reports share. Written atomically, so an
// interrupted sweep never leaves a half-written file. Cells holding a comma, quote or line break
// are quoted (RFC 4180).
#pragma once

#include <string>
#include <vector>

namespace handscs {

struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  int column(const std::string& name) const;  // index of a header cell, -1 if absent
  // Cell of `row` in column `name`; throws Error when the column does not exist.
  const std::string& at(size_t row, const std::string& name) const;
};

// One cell as CSV writes it: quoted (quotes doubled) when it holds a comma, quote or line break.
std::string csv_cell(const std::string& cell);

// Reads a CSV file; every row must have as many cells as the header (errors name file and line).
CsvTable read_csv(const std::string& path);
void write_csv_atomic(const std::string& path, const CsvTable& table);

}  // namespace handscs
