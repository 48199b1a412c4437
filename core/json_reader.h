// Reading JSON back (sweep.json, run.json) with Debian's nlohmann-json: a maintained parser,
// wrapped so that every failure is an InputError (exit 3) naming the file and the byte offset,
// and nesting deeper than a limit is refused before parsing (radlab writes at most 4 levels; the
// limit keeps hostile input from exhausting the stack or memory in the parser or the destructor).
// Objects keep their key order (ordered_json), so a file read and written back keeps its layout.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/json.h"

namespace radlab {

using Json = nlohmann::ordered_json;

constexpr size_t kJsonMaxDepth = 64;

// Parses `text`; `name` (a file path) starts every error message, which gives the offset (from
// 0) of the byte at fault.
Json parse_json(const std::string& text, const std::string& name, size_t max_depth = kJsonMaxDepth);

// Reads and parses a file; a missing or unreadable file is an InputError too.
Json read_json_file(const std::string& path, size_t max_depth = kJsonMaxDepth);

// Writes a parsed value with radlab's writer (same layout and number format as the original).
void write_json_value(JsonWriter& json, const Json& value);

}  // namespace radlab
