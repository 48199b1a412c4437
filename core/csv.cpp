#include "core/csv.h"

#include <cmath>

#include "core/error.h"
#include "core/text.h"

namespace radlab {

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + '"';
}

CsvWriter::CsvWriter(const std::string& path, std::vector<std::string> columns)
    : path_(path), out_(path), columns_(std::move(columns)) {
  if (!out_) throw InputError(path + ": cannot write file");
  for (size_t k = 0; k < columns_.size(); ++k) out_ << (k ? "," : "") << columns_[k];
  out_ << '\n';
}

CsvWriter& CsvWriter::add(const std::string& text) {
  fields_.push_back(csv_field(text));
  return *this;
}

CsvWriter& CsvWriter::add(double number) {
  fields_.push_back(std::isnan(number) ? std::string() : text::format_double(number));
  return *this;
}

CsvWriter& CsvWriter::add(long long number) {
  fields_.push_back(std::to_string(number));
  return *this;
}

CsvWriter& CsvWriter::add(unsigned long long number) {
  fields_.push_back(std::to_string(number));
  return *this;
}

void CsvWriter::end_row() {
  if (fields_.size() != columns_.size())
    throw std::logic_error(path_ + ": CSV row has " + std::to_string(fields_.size()) +
                           " fields, header has " + std::to_string(columns_.size()));
  for (size_t k = 0; k < fields_.size(); ++k) out_ << (k ? "," : "") << fields_[k];
  out_ << '\n';
  fields_.clear();
  if (!out_) throw InputError(path_ + ": write failed");
}

}  // namespace radlab
