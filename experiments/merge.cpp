#include "experiments/merge.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/csv.h"
#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json.h"
#include "core/text.h"

namespace radlab {
namespace {

void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<const std::vector<std::string>*>& rows) {
  std::ofstream out(path);
  if (!out) throw InputError(path + ": cannot write file");
  for (size_t k = 0; k < header.size(); ++k) out << (k ? "," : "") << csv_field(header[k]);
  out << '\n';
  for (const auto* row : rows) {
    for (size_t k = 0; k < row->size(); ++k) out << (k ? "," : "") << csv_field((*row)[k]);
    out << '\n';
  }
}

void copy_folder(const std::filesystem::path& from, const std::filesystem::path& to) {
  namespace fs = std::filesystem;
  if (!fs::exists(from)) return;
  fs::create_directories(to);
  for (const auto& entry : fs::directory_iterator(from))
    if (entry.is_regular_file())
      fs::copy_file(entry.path(), to / entry.path().filename(),
                    fs::copy_options::overwrite_existing);
}

// Just enough JSON to read back the sweep.json files radlab writes (core/json.h only writes):
// the values keep their order, numbers keep their text.
struct JsonNode {
  enum Kind { kNull, kBool, kNumber, kString, kArray, kObject } kind = kNull;
  std::string text;                // bool/number literal, or the string's value
  std::vector<std::string> keys;   // kObject
  std::vector<JsonNode> children;  // kArray items, or kObject values (beside keys)

  const JsonNode* find(const std::string& key) const {
    for (size_t k = 0; k < keys.size(); ++k)
      if (keys[k] == key) return &children[k];
    return nullptr;
  }
  JsonNode* find(const std::string& key) {
    return const_cast<JsonNode*>(static_cast<const JsonNode*>(this)->find(key));
  }
};

class JsonParser {
 public:
  JsonParser(std::string text, std::string path) : s_(std::move(text)), path_(std::move(path)) {}

  JsonNode parse() {
    JsonNode node = value();
    space();
    if (pos_ != s_.size()) fail("unexpected text after the JSON value");
    return node;
  }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(path_ + ": bad JSON at byte " + std::to_string(pos_) + ": " + message);
  }
  void space() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  char peek() {
    space();
    if (pos_ >= s_.size()) fail("unexpected end");
    return s_[pos_];
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  bool literal(const char* word) {
    const std::string w(word);
    if (s_.compare(pos_, w.size(), w) != 0) return false;
    pos_ += w.size();
    return true;
  }
  std::string string() {
    expect('"');
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      char c = s_[pos_++];
      if (c != '\\') {
        out += c;
        continue;
      }
      if (pos_ >= s_.size()) fail("unterminated escape");
      c = s_[pos_++];
      switch (c) {
        case 'n':
          out += '\n';
          break;
        case 't':
          out += '\t';
          break;
        case 'r':
          out += '\r';
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'u': {
          if (pos_ + 4 > s_.size()) fail("short \\u escape");
          const unsigned code = unsigned(std::stoul(s_.substr(pos_, 4), nullptr, 16));
          pos_ += 4;
          if (code < 0x80) {
            out += char(code);
          } else if (code < 0x800) {
            out += char(0xC0 | (code >> 6));
            out += char(0x80 | (code & 0x3F));
          } else {
            out += char(0xE0 | (code >> 12));
            out += char(0x80 | ((code >> 6) & 0x3F));
            out += char(0x80 | (code & 0x3F));
          }
          break;
        }
        default:
          out += c;  // " \\ /
      }
    }
    if (pos_ >= s_.size()) fail("unterminated string");
    ++pos_;
    return out;
  }
  JsonNode value() {
    JsonNode node;
    const char c = peek();
    if (c == '{') {
      node.kind = JsonNode::kObject;
      ++pos_;
      if (peek() == '}') return ++pos_, node;
      for (;;) {
        node.keys.push_back(string());
        expect(':');
        node.children.push_back(value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect('}');
        return node;
      }
    }
    if (c == '[') {
      node.kind = JsonNode::kArray;
      ++pos_;
      if (peek() == ']') return ++pos_, node;
      for (;;) {
        node.children.push_back(value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect(']');
        return node;
      }
    }
    if (c == '"') {
      node.kind = JsonNode::kString;
      node.text = string();
      return node;
    }
    if (literal("null")) return node;
    if (literal("true") || literal("false")) {
      node.kind = JsonNode::kBool;
      node.text = s_[pos_ - 1] == 'e' && s_[pos_ - 2] == 'u' ? "true" : "false";
      return node;
    }
    const size_t start = pos_;
    while (pos_ < s_.size() && std::strchr("+-0123456789.eE", s_[pos_])) ++pos_;
    if (pos_ == start) fail(std::string("unexpected '") + c + "'");
    node.kind = JsonNode::kNumber;
    node.text = s_.substr(start, pos_ - start);
    return node;
  }

  std::string s_, path_;
  size_t pos_ = 0;
};

JsonNode read_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": no such file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return JsonParser(buffer.str(), path).parse();
}

void write_json(JsonWriter& json, const JsonNode& node) {
  switch (node.kind) {
    case JsonNode::kNull:
      json.null();
      break;
    case JsonNode::kBool:
      json.value(node.text == "true");
      break;
    case JsonNode::kNumber:
      if (node.text.find_first_of(".eE") != std::string::npos)
        json.value(std::strtod(node.text.c_str(), nullptr));
      else if (node.text[0] == '-')
        json.value(std::stoll(node.text));
      else
        json.value(static_cast<unsigned long long>(std::stoull(node.text)));
      break;
    case JsonNode::kString:
      json.value(node.text);
      break;
    case JsonNode::kArray:
      json.begin_array();
      for (const JsonNode& child : node.children) write_json(json, child);
      json.end_array();
      break;
    case JsonNode::kObject:
      json.begin_object();
      for (size_t k = 0; k < node.keys.size(); ++k) {
        json.key(node.keys[k]);
        write_json(json, node.children[k]);
      }
      json.end_object();
      break;
  }
}

JsonNode json_string(const std::string& text) {
  JsonNode node;
  node.kind = JsonNode::kString;
  node.text = text;
  return node;
}

// Array items of `key` from every shard, ordered by their numeric field `order_key` (items
// with the same order value, e.g. one problem seen by two shards, are kept once).
JsonNode merged_array(const std::vector<JsonNode>& sweeps, const std::string& key,
                      const std::string& order_key) {
  std::map<long long, JsonNode> by_order;
  for (const JsonNode& sweep : sweeps)
    if (const JsonNode* array = sweep.find(key))
      for (const JsonNode& item : array->children) {
        const JsonNode* order = item.find(order_key);
        by_order.emplace(order ? std::stoll(order->text) : 0, item);
      }
  JsonNode out;
  out.kind = JsonNode::kArray;
  for (auto& [order, item] : by_order) out.children.push_back(item);
  return out;
}

}  // namespace

size_t merge_sweeps(const std::vector<std::string>& dirs, const std::string& out_dir,
                    const std::string& command) {
  namespace fs = std::filesystem;
  if (dirs.empty()) throw UsageError("merge: give at least one shard folder");
  std::vector<CsvTable> summaries, traces;
  for (const std::string& dir : dirs) {
    summaries.push_back(read_csv((fs::path(dir) / "summary.csv").string()));
    traces.push_back(read_csv((fs::path(dir) / "trace.csv").string()));
    if (summaries.back().header != summaries.front().header)
      throw InputError(summaries.back().path + ": summary columns differ from " +
                       summaries.front().path);
    if (traces.back().header != traces.front().header)
      throw InputError(traces.back().path + ": trace columns differ from " + traces.front().path);
  }

  // Summary rows in the sweep's run order.
  std::vector<std::pair<long long, const std::vector<std::string>*>> ordered;
  std::map<std::string, std::string> seen;  // run_id -> shard
  for (size_t s = 0; s < summaries.size(); ++s) {
    const size_t index_column = summaries[s].column("run_index");
    const size_t id_column = summaries[s].column("run_id");
    for (const auto& row : summaries[s].rows) {
      auto index = text::parse_int(row[index_column]);
      if (!index)
        throw InputError(summaries[s].path + ": bad run_index '" + row[index_column] + "'");
      if (!seen.emplace(row[id_column], dirs[s]).second)
        throw InputError("merge: run '" + row[id_column] + "' is in " + seen[row[id_column]] +
                         " and in " + dirs[s]);
      ordered.emplace_back(*index, &row);
    }
  }
  std::sort(ordered.begin(), ordered.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });

  // Trace rows grouped by run, each run's rows in their original order.
  std::map<std::string, std::vector<const std::vector<std::string>*>> by_run;
  for (const CsvTable& t : traces) {
    const size_t id = t.column("run_id");
    for (const auto& row : t.rows) by_run[row[id]].push_back(&row);
  }

  fs::create_directories(out_dir);
  std::vector<const std::vector<std::string>*> summary_rows, trace_rows;
  const size_t id_column = summaries.front().column("run_id");
  for (const auto& [index, row] : ordered) {
    summary_rows.push_back(row);
    for (const auto* t : by_run[(*row)[id_column]]) trace_rows.push_back(t);
  }
  write_rows((fs::path(out_dir) / "summary.csv").string(), summaries.front().header, summary_rows);
  write_rows((fs::path(out_dir) / "trace.csv").string(), traces.front().header, trace_rows);
  for (const std::string& dir : dirs) {
    copy_folder(fs::path(dir) / "runs", fs::path(out_dir) / "runs");
    copy_folder(fs::path(dir) / "images", fs::path(out_dir) / "images");
    copy_folder(fs::path(dir) / "coverage", fs::path(out_dir) / "coverage");
  }

  // sweep.json: the unsplit run's, with every shard's runs, failures and problems in the sweep's
  // order; `merged_from` names the shards and their commands.
  std::vector<JsonNode> sweeps;
  for (const std::string& dir : dirs) {
    sweeps.push_back(read_json((fs::path(dir) / "sweep.json").string()));
    for (const char* key : {"experiment", "name", "runs_total"}) {
      const JsonNode* a = sweeps.front().find(key);
      const JsonNode* b = sweeps.back().find(key);
      if (!a || !b || a->text != b->text)
        throw InputError("merge: " + dir + "/sweep.json: '" + key + "' differs from " +
                         dirs.front() + "/sweep.json (shards of different experiments?)");
    }
  }
  JsonNode merged = sweeps.front();
  if (!command.empty())
    if (JsonNode* c = merged.find("command")) *c = json_string(command);
  if (JsonNode* shard = merged.find("shard")) *shard = json_string("0/1");
  if (JsonNode* runs = merged.find("runs")) {
    runs->children.clear();
    for (const auto* row : summary_rows) runs->children.push_back(json_string((*row)[id_column]));
  }
  if (JsonNode* failed = merged.find("failed"))
    *failed = merged_array(sweeps, "failed", "run_index");
  if (JsonNode* problems = merged.find("problems"))
    *problems = merged_array(sweeps, "problems", "index");
  JsonNode from;
  from.kind = JsonNode::kArray;
  for (size_t s = 0; s < dirs.size(); ++s) {
    JsonNode entry;
    entry.kind = JsonNode::kObject;
    entry.keys = {"folder", "shard", "command"};
    auto text_of = [&](const char* key) {
      const JsonNode* n = sweeps[s].find(key);
      return n ? n->text : std::string();
    };
    entry.children = {json_string(dirs[s]), json_string(text_of("shard")),
                      json_string(text_of("command"))};
    from.children.push_back(entry);
  }
  merged.keys.push_back("merged_from");
  merged.children.push_back(from);
  JsonWriter json;
  write_json(json, merged);
  json.save((fs::path(out_dir) / "sweep.json").string());
  return ordered.size();
}

}  // namespace radlab
