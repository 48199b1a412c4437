// Shared helpers of the libFuzzer harnesses (fuzz/*_fuzz.cpp).
//
// A harness gets one byte string; readers that take several files (OBJ + MTL, MGF + include,
// a sweep folder) get them as parts of it, separated by the line `#--8<--` (fuzz/radlab.dict
// tells libFuzzer about the marker, so mutations move and duplicate it). The parts are written
// into one private temporary folder per process, reused by every execution.
//
// What counts as a finding: anything but a return or a radlab::Error (the readers' documented
// way to refuse input: exit 2/3/4 on the command line). Any other exception escapes, and
// libFuzzer reports it as a crash ("internal error" on the command line), like a sanitizer
// report, a timeout (a hang) or an allocation above -malloc_limit_mb (unbounded memory).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace radlab::fuzz {

// Lowers the resource limits (core/limits.h) for fuzzing: inputs then reach the refusals
// with little work, and a timeout means work that no estimate bounds (a real hang), not a large but
// allowed scene. Called once from each harness's LLVMFuzzerInitialize.
void set_fuzz_limits();

// Splits at the marker line; always returns at least `parts` entries (missing ones empty).
std::vector<std::string> split_parts(const uint8_t* data, size_t size, size_t parts);

// The process's scratch folder (created once, emptied by clear_scratch()).
const std::filesystem::path& scratch();
void clear_scratch();
void write_file(const std::filesystem::path& path, std::string_view text);

}  // namespace radlab::fuzz
