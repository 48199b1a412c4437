#include "core/json_reader.h"

#include <fstream>
#include <sstream>

#include "core/error.h"

namespace radlab {

Json parse_json(const std::string& text, const std::string& name, size_t max_depth) {
  // Depth first, outside strings: a bracket inside a string does not nest.
  size_t depth = 0;
  bool in_string = false;
  for (size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (in_string) {
      if (c == '\\')
        ++k;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth)
        throw InputError(name + ": bad JSON at byte " + std::to_string(k) +
                         ": nested deeper than " + std::to_string(max_depth) + " levels");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  try {
    return Json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.what() is "[json.exception.parse_error.101] parse error at line 1, column 5: ...".
    std::string what = e.what();
    const size_t at = what.find("] ");
    if (at != std::string::npos) what = what.substr(at + 2);
    // nlohmann counts the bytes read, the offending one included; offsets here start at 0.
    const size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    throw InputError(name + ": bad JSON at byte " + std::to_string(offset) + ": " + what);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(name + ": bad JSON: " + e.what());
  }
}

Json read_json_file(const std::string& path, size_t max_depth) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error");
  return parse_json(buffer.str(), path, max_depth);
}

void write_json_value(JsonWriter& json, const Json& value) {
  switch (value.type()) {
    case Json::value_t::null:
    case Json::value_t::discarded:
      json.null();
      break;
    case Json::value_t::boolean:
      json.value(value.get<bool>());
      break;
    case Json::value_t::number_integer:
      json.value(value.get<long long>());
      break;
    case Json::value_t::number_unsigned:
      json.value(value.get<unsigned long long>());
      break;
    case Json::value_t::number_float:
      json.value(value.get<double>());
      break;
    case Json::value_t::string:
      json.value(value.get<std::string>());
      break;
    case Json::value_t::binary:
      json.null();
      break;
    case Json::value_t::array:
      json.begin_array();
      for (const Json& item : value) write_json_value(json, item);
      json.end_array();
      break;
    case Json::value_t::object:
      json.begin_object();
      for (const auto& [key, item] : value.items()) {
        json.key(key);
        write_json_value(json, item);
      }
      json.end_object();
      break;
  }
}

}  // namespace radlab
