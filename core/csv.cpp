#include "core/csv.h"

#include <cmath>
#include <exception>

#include "core/error.h"
#include "core/log.h"
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
    : path_(path),
      out_(std::make_unique<OutputFile>(path)),
      columns_(std::move(columns)),
      uncaught_(std::uncaught_exceptions()) {
  std::string line;
  for (size_t k = 0; k < columns_.size(); ++k) line += (k ? "," : "") + columns_[k];
  out_->write(line + '\n');
}

CsvWriter::~CsvWriter() {
  if (!out_ || out_->committed() || std::uncaught_exceptions() > uncaught_) return;
  try {
    out_->commit();
  } catch (const std::exception& e) {
    log::warning(e.what());
  }
}

void CsvWriter::flush() {
  out_->flush();
}

void CsvWriter::close() {
  out_->commit();
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
  std::string line;
  for (size_t k = 0; k < fields_.size(); ++k) line += (k ? "," : "") + fields_[k];
  line += '\n';
  out_->write(line);
  fields_.clear();
}

}  // namespace radlab
