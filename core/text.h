// Small string helpers shared by the readers and the command line: strict number parsing (the
// whole token must be a number, NaN and infinities are rejected unless asked for) and
// shortest round-trip formatting of doubles for CSV, run ids and messages.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace radlab::text {

std::string_view trim(std::string_view s);
std::vector<std::string_view> split_whitespace(std::string_view s);
std::vector<std::string> split(std::string_view s, char separator);
bool starts_with(std::string_view s, std::string_view prefix);
std::string to_lower(std::string_view s);

// Strict parsing: the whole of `s` must be the number. Returns nullopt otherwise.
std::optional<double> parse_double(std::string_view s);
std::optional<long long> parse_int(std::string_view s);
std::optional<bool> parse_bool(std::string_view s);

// The shortest text that reads back as the same double (std::to_chars): exact round trip, and
// 0.6 prints as "0.6" in run ids and messages. Non-finite values print as "nan", "inf", "-inf".
std::string format_double(double value);

// Joins with a separator, e.g. the list of valid keys in an error message.
std::string join(const std::vector<std::string>& items, std::string_view separator);

// A word read from a file as a message may quote it: at most `max_chars` characters, control and
// non-ASCII bytes as '?', "..." when cut. An error then never echoes a file's contents (a
// misnamed /etc/passwd, a binary file) beyond a few bytes.
std::string printable_prefix(std::string_view word, size_t max_chars);

}  // namespace radlab::text
