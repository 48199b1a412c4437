// CSV output with a fixed header: every row must have exactly the header's columns, so columns
// cannot drift (DESIGN §8). Doubles are written "%.17g"; NaN (not applicable) as an empty field.
#pragma once

#include <fstream>
#include <string>
#include <vector>

namespace radlab {

class CsvWriter {
 public:
  CsvWriter(const std::string& path, std::vector<std::string> columns);
  const std::vector<std::string>& columns() const { return columns_; }

  // Row building: add fields in header order, then end_row() checks the count.
  CsvWriter& add(const std::string& text);
  CsvWriter& add(double number);
  CsvWriter& add(long long number);
  CsvWriter& add(unsigned long long number);
  CsvWriter& add(int number) { return add(static_cast<long long>(number)); }
  CsvWriter& add(size_t number) { return add(static_cast<unsigned long long>(number)); }
  void end_row();
  void flush() { out_.flush(); }

 private:
  std::string path_;
  std::ofstream out_;
  std::vector<std::string> columns_;
  std::vector<std::string> fields_;
};

// Quotes a field if it holds a comma, quote or newline.
std::string csv_field(const std::string& text);

}  // namespace radlab
