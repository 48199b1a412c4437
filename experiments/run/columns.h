// Output columns as data: a table of {name, meaning, how it is computed} per CSV file. The
// table generates the file's header, every row (each entry adds its one field), and the column
// table of docs/outputs.md (column_table_markdown; a test keeps the page equal to it). Adding a
// metric is one entry appended to a table (docs/outputs.md: existing columns keep their names and
// order, new ones are appended).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/csv.h"

namespace radlab {

template <class Record>
struct Column {
  std::string name;
  std::string meaning;  // one line of markdown: docs/outputs.md's row for it
  // Adds exactly this column's field for one record.
  std::function<void(CsvWriter&, const Record&)> write;
  // The value measures the machine (seconds): left out when re-runs are compared
  // (scripts/compare_sweeps.py, summary_time_columns).
  bool time = false;
};

template <class Record>
using ColumnTable = std::vector<Column<Record>>;

template <class Record>
std::vector<std::string> column_names(const ColumnTable<Record>& table) {
  std::vector<std::string> names;
  for (const Column<Record>& c : table) names.push_back(c.name);
  return names;
}

// One row: every column's field in table order, then the row is checked and ended.
template <class Record>
void write_columns(CsvWriter& csv, const ColumnTable<Record>& table, const Record& record) {
  for (const Column<Record>& c : table) c.write(csv, record);
  csv.end_row();
}

// "| column | meaning |" and one line per column, as docs/outputs.md shows the table.
template <class Record>
std::string column_table_markdown(const ColumnTable<Record>& table) {
  std::string text = "| column | meaning |\n|---|---|\n";
  for (const Column<Record>& c : table) text += "| `" + c.name + "` | " + c.meaning + " |\n";
  return text;
}

// A run's statistics (Solver::statistics(): links, rays, refinements, ...) as one CSV field,
// `name=value;name=value` (values %.10g). Those that measure the machine (a name holding
// "seconds" or "rss": time, the process's peak memory) stay in run.json only: the CSVs are
// compared across re-runs without their time columns.
std::string statistics_field(const std::vector<std::pair<std::string, double>>& statistics);

}  // namespace radlab
