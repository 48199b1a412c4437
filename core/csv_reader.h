// Reads a CSV file with a header row (as written by CsvWriter): quoted fields, doubled quotes,
// and quoted fields spanning lines (a record continues while a quote is open), so whatever
// CsvWriter writes reads back field for field.
// Used by `radlab merge` and the tests.
#pragma once

#include <string>
#include <vector>

namespace radlab {

struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  // Index of a column; throws InputError naming the file if it is missing.
  size_t column(const std::string& name) const;
  std::string path;
};

// Throws InputError naming the file (and line) when it cannot be read or a row's field count
// differs from the header's.
CsvTable read_csv(const std::string& path);

// Splits one CSV record (newlines allowed inside quoted fields) into fields.
std::vector<std::string> split_csv_line(const std::string& line);

}  // namespace radlab
