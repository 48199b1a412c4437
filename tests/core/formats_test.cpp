// The core library's formats on their own: CSV written and read back field for field (newlines,
// quotes, commas inside fields), numbers as the shortest text that reads back exactly, strict
// number parsing, JSON written and parsed back, and the defaults a ParamBag records.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "core/csv.h"
#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json.h"
#include "core/json_reader.h"
#include "core/param_bag.h"
#include "core/progress.h"
#include "core/random.h"
#include "core/text.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using radlab::testing::TempDir;

TEST(Csv, WhatTheWriterWritesTheReaderReadsBack) {
  // summary.csv's error column holds messages with newlines (radlab merge reads it back).
  const std::vector<std::string> texts = {
      "plain",      "with, comma", "with \"quotes\"", "two\nlines", "crlf\r\nline", "\"\n\"", "",
      "trailing\n", "\n",          "a,\"b\"\nc,d",
  };
  TempDir dir;
  const std::string path = dir.file("t.csv");
  {
    CsvWriter csv(path, {"index", "text", "number"});
    for (size_t k = 0; k < texts.size(); ++k)
      csv.add(static_cast<long long>(k)).add(texts[k]).add(0.1 * double(k)).end_row();
    csv.close();
  }
  const CsvTable table = read_csv(path);
  ASSERT_EQ(table.rows.size(), texts.size());
  for (size_t k = 0; k < texts.size(); ++k) {
    EXPECT_EQ(table.rows[k][0], std::to_string(k));
    EXPECT_EQ(table.rows[k][1], texts[k]) << "row " << k;
    EXPECT_EQ(text::parse_double(table.rows[k][2]), 0.1 * double(k));
  }
}

TEST(Csv, AnUnclosedQuoteNamesTheFileAndLine) {
  TempDir dir;
  const std::string path = dir.write("bad.csv", "a,b\n1,2\n3,\"open\nstill open\n");
  testing::expect_error<InputError>([&] { read_csv(path); }, {"bad.csv:3", "not closed"});
}

TEST(Csv, AShortRowNamesItsLine) {
  TempDir dir;
  const std::string path = dir.write("short.csv", "a,b\n1,\"x\ny\"\n2\n");
  // The record of lines 2-3 is whole; line 4 has one field.
  testing::expect_error<InputError>([&] { read_csv(path); }, {"short.csv:4", "1 fields"});
}

TEST(Text, DoublesPrintShortestAndReadBackExactly) {
  EXPECT_EQ(text::format_double(0.1), "0.1");
  EXPECT_EQ(text::format_double(0.6), "0.6");  // was 0.59999999999999998 in run ids
  EXPECT_EQ(text::format_double(-1e-9), "-1e-09");
  EXPECT_EQ(text::format_double(1.0), "1");
  EXPECT_EQ(text::format_double(1e-4), "1e-04");  // shorter than 0.0001
  EXPECT_EQ(text::format_double(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(text::format_double(-std::numeric_limits<double>::infinity()), "-inf");
  // Round trip of random bit patterns (every finite double is a candidate), seeded.
  Pcg32 rng(15);
  int checked = 0;
  for (int k = 0; k < 20000; ++k) {
    const uint64_t bits = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
    double value;
    std::memcpy(&value, &bits, sizeof value);
    if (!std::isfinite(value)) continue;
    const auto back = text::parse_double(text::format_double(value));
    ASSERT_TRUE(back) << text::format_double(value);
    ASSERT_EQ(*back, value) << text::format_double(value);
    ++checked;
  }
  EXPECT_GT(checked, 19000);
}

TEST(Text, ParsingIsStrict) {
  EXPECT_EQ(text::parse_double(" 2.5 "), 2.5);
  EXPECT_FALSE(text::parse_double("2.5x"));
  EXPECT_FALSE(text::parse_double(""));
  EXPECT_EQ(text::parse_int("+7"), 7);
  EXPECT_FALSE(text::parse_int("7.0"));
  EXPECT_FALSE(text::parse_int("99999999999999999999"));  // out of range, not wrapped
  EXPECT_EQ(text::parse_bool("Yes"), true);
  EXPECT_EQ(text::parse_bool("off"), false);
  EXPECT_FALSE(text::parse_bool("maybe"));
  EXPECT_EQ(text::split("a::b", ':'), (std::vector<std::string>{"a", "", "b"}));
  EXPECT_EQ(text::join({"x", "y"}, ", "), "x, y");
}

TEST(Json, NumbersAreShortestAndParseBack) {
  JsonWriter json;
  json.begin_object().field("a", 0.1).field("b", -1e-9).field("c", std::nan("")).end_object();
  EXPECT_NE(json.str().find("0.1"), std::string::npos) << json.str();
  EXPECT_EQ(json.str().find("0.10000000000000001"), std::string::npos) << json.str();
  const Json parsed = parse_json(json.str(), "t.json");
  EXPECT_EQ(parsed["a"].get<double>(), 0.1);
  EXPECT_EQ(parsed["b"].get<double>(), -1e-9);
  EXPECT_TRUE(parsed["c"].is_null());  // JSON has no NaN
  JsonWriter again;
  write_json_value(again, parsed);
  EXPECT_EQ(again.str(), json.str());
}

TEST(Json, BadInputIsAnInputErrorNamingTheFile) {
  testing::expect_error<InputError>([] { parse_json("{\"a\": [1, 2", "run.json"); }, {"run.json"});
}

TEST(ParamBag, RecordsTheDefaultOfEveryKeyRead) {
  ParamBag bag("test");
  bag.set("given", "3");
  EXPECT_EQ(bag.get_double("omega", 0.6), 0.6);
  EXPECT_EQ(bag.get_int("given", 1), 3);
  EXPECT_EQ(bag.get_bool("flag", false), false);
  EXPECT_EQ(bag.get_choice("mode", "fast", {"fast", "slow"}), "fast");
  const std::map<std::string, std::string> expected = {
      {"omega", "0.6"}, {"given", "1"}, {"flag", "false"}, {"mode", "fast"}};
  EXPECT_EQ(bag.defaults(), expected);
}

}  // namespace
}  // namespace radlab

// Long work writing to a log (not a terminal, as under ctest, Slurm or CI) must show that it is
// moving: lines while it runs, not only at the start and the end. With the interval at 0 every
// update is a whole line ending in a newline (no carriage-return redraws in a log file).
TEST(Progress, ALogGetsLinesWhileTheWorkRuns) {
  radlab::Progress::set_log_interval(std::chrono::milliseconds(0));
  testing::internal::CaptureStderr();
  {
    radlab::Progress progress("form factors", "rows", 4);
    for (int done = 1; done <= 3; ++done) progress.update(done);
    progress.finish();
  }
  const std::string text = testing::internal::GetCapturedStderr();
  radlab::Progress::set_log_interval(std::chrono::milliseconds(60000));
  EXPECT_NE(text.find("form factors: 3/4 rows"), std::string::npos) << text;
  EXPECT_EQ(text.find('\r'), std::string::npos) << text;
  EXPECT_NE(text.find("form factors: done in"), std::string::npos) << text;
}
