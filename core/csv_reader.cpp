#include "core/csv_reader.h"

#include <fstream>

#include "core/error.h"

namespace radlab {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t k = 0; k < line.size(); ++k) {
    const char c = line[k];
    if (quoted) {
      if (c == '"' && k + 1 < line.size() && line[k + 1] == '"') {
        fields.back() += '"';
        ++k;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

namespace {

// True when `record` ends inside a quoted field: the record continues on the next line (the
// writer quotes fields holding newlines, e.g. an error message in summary.csv).
bool inside_quotes(const std::string& record) {
  bool quoted = false;
  for (char c : record)
    if (c == '"') quoted = !quoted;  // a doubled quote toggles twice
  return quoted;
}

}  // namespace

CsvTable read_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open file");
  CsvTable table;
  table.path = path;
  std::string line;
  if (!std::getline(in, line)) throw InputError(path + ": empty file (no CSV header)");
  table.header = split_csv_line(line);
  int number = 1;
  while (std::getline(in, line)) {
    const int first = ++number;
    std::string record = line;
    while (inside_quotes(record)) {
      if (!std::getline(in, line))
        throw InputError(path + ":" + std::to_string(first) +
                         ": a quoted field is not closed before the end of the file");
      ++number;
      record += '\n' + line;
    }
    if (record.empty()) continue;
    auto fields = split_csv_line(record);
    if (fields.size() != table.header.size())
      throw InputError(path + ":" + std::to_string(first) + ": " + std::to_string(fields.size()) +
                       " fields, the header has " + std::to_string(table.header.size()));
    table.rows.push_back(std::move(fields));
  }
  return table;
}

size_t CsvTable::column(const std::string& name) const {
  for (size_t k = 0; k < header.size(); ++k)
    if (header[k] == name) return k;
  throw InputError(path + ": no column '" + name + "'");
}

}  // namespace radlab
