// CSV output with a fixed header: every row must have exactly the header's columns, so columns
// cannot drift (DESIGN §8). Doubles are written "%.17g"; NaN (not applicable) as an empty field.
// The file is written to a temporary name and appears under its own name only when close()
// has checked every byte reached the disk (core/output_file.h); a failed write throws
// InputError.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/output_file.h"

namespace radlab {

class CsvWriter {
 public:
  CsvWriter(const std::string& path, std::vector<std::string> columns);
  // Without close(), the destructor still renames the file into place when no exception is
  // propagating (and only warns if that fails); every command calls close() to see errors.
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;
  const std::vector<std::string>& columns() const { return columns_; }

  // Row building: add fields in header order, then end_row() checks the count.
  CsvWriter& add(const std::string& text);
  CsvWriter& add(double number);
  CsvWriter& add(long long number);
  CsvWriter& add(unsigned long long number);
  CsvWriter& add(int number) { return add(static_cast<long long>(number)); }
  CsvWriter& add(size_t number) { return add(static_cast<unsigned long long>(number)); }
  void end_row();
  // Hands the rows so far to the system (errors so far throw).
  void flush();
  // Closes, checks and renames the file into place; throws InputError naming it on failure.
  void close();

 private:
  std::string path_;
  std::unique_ptr<OutputFile> out_;
  std::vector<std::string> columns_;
  int uncaught_ = 0;
  std::vector<std::string> fields_;
};

// Quotes a field if it holds a comma, quote or newline.
std::string csv_field(const std::string& text);

}  // namespace radlab
