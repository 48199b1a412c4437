// A small JSON writer for run.json: objects, arrays, strings, numbers, booleans. Numbers are
// written shortest-round-trip (text::format_double); non-finite numbers become null (JSON has no
// NaN).
#pragma once

#include <string>
#include <vector>

namespace radlab {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  JsonWriter& key(const std::string& name);
  JsonWriter& value(const std::string& text);
  JsonWriter& value(const char* text) { return value(std::string(text)); }
  JsonWriter& value(double number);
  JsonWriter& value(long long number);
  JsonWriter& value(unsigned long long number);
  JsonWriter& value(int number) { return value(static_cast<long long>(number)); }
  JsonWriter& value(size_t number) { return value(static_cast<unsigned long long>(number)); }
  JsonWriter& value(bool flag);
  JsonWriter& null();
  // key + value in one call.
  template <class T>
  JsonWriter& field(const std::string& name, const T& v) {
    key(name);
    return value(v);
  }
  JsonWriter& field(const std::string& name, const std::vector<std::string>& items);

  const std::string& str() const { return out_; }
  // Writes to `path` through a temporary name (core/output_file.h); throws InputError
  // naming the file if it cannot.
  void save(const std::string& path) const;

 private:
  void separator();
  void indent();
  std::string out_;
  std::vector<bool> first_;  // per open container: no element written yet
  bool after_key_ = false;
};

std::string json_escape(const std::string& text);

}  // namespace radlab
