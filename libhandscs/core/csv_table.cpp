#include "core/csv_table.h"

#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

namespace {

// Splits one CSV record; quoted cells may hold commas and doubled quotes.
std::vector<std::string> split_record(const std::string& line, const std::string& where) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char ch = line[i];
    if (quoted) {
      if (ch == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cells.back() += '"';
        ++i;
      } else if (ch == '"') {
        quoted = false;
      } else {
        cells.back() += ch;
      }
    } else if (ch == '"') {
      quoted = true;
    } else if (ch == ',') {
      cells.emplace_back();
    } else if (ch != '\r') {
      cells.back() += ch;
    }
  }
  if (quoted) throw Error(where + ": unterminated quoted cell");
  return cells;
}

}  // namespace

std::string csv_cell(const std::string& cell) {
  if (cell.find_first_of(",\"\n\r") == std::string::npos) return cell;
  std::string out = "\"";
  for (char ch : cell) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

int CsvTable::column(const std::string& name) const {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

const std::string& CsvTable::at(size_t row, const std::string& name) const {
  const int c = column(name);
  if (c < 0) throw Error("CSV: no column \"" + name + "\"");
  return rows.at(row).at(static_cast<size_t>(c));
}

CsvTable read_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open");
  CsvTable table;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line == "\r") continue;
    auto cells = split_record(line, path + ":" + std::to_string(number));
    if (table.header.empty()) {
      table.header = std::move(cells);
      continue;
    }
    if (cells.size() != table.header.size())
      throw Error(path + ":" + std::to_string(number) + ": " + std::to_string(cells.size()) +
                  " cells, the header has " + std::to_string(table.header.size()));
    table.rows.push_back(std::move(cells));
  }
  if (table.header.empty()) throw Error(path + ": empty file (no header)");
  return table;
}

void write_csv_atomic(const std::string& path, const CsvTable& table) {
  std::ostringstream out;
  auto write_row = [&](const std::vector<std::string>& cells) {
    for (size_t i = 0; i < cells.size(); ++i) out << (i ? "," : "") << csv_cell(cells[i]);
    out << "\n";
  };
  write_row(table.header);
  for (const auto& row : table.rows) write_row(row);
  write_file_atomic(path, out.str());
}

}  // namespace handscs
