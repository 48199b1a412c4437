// Replays every committed fuzz corpus file (fuzz/corpus/HARNESS/: the seeds and every finding of
// scripts/fuzz.sh, once fixed) through its fuzz target (fuzz/targets.h). A target returns when
// the input is read or refused with a radlab::Error; a crash, a sanitizer report (in the
// scripts/test.sh --sanitize build) or any other exception fails the test, naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fuzz/targets.h"

namespace radlab {
namespace {

using Target = void (*)(const uint8_t*, size_t);

struct Harness {
  const char* name;
  Target target;
};

void PrintTo(const Harness& h, std::ostream* out) {
  *out << h.name;
}

class FuzzCorpus : public ::testing::TestWithParam<Harness> {};

TEST_P(FuzzCorpus, EveryFileIsReadOrRefusedCleanly) {
  const std::filesystem::path folder =
      std::filesystem::path(RADLAB_SOURCE_DIR) / "fuzz" / "corpus" / GetParam().name;
  ASSERT_TRUE(std::filesystem::is_directory(folder)) << folder;
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.is_regular_file()) files.push_back(entry.path());
  ASSERT_FALSE(files.empty()) << folder;
  for (const auto& file : files) {
    std::string data(std::filesystem::file_size(file), '\0');
    std::ifstream(file, std::ios::binary).read(data.data(), std::streamsize(data.size()));
    SCOPED_TRACE(file.string());
    EXPECT_NO_THROW(GetParam().target(reinterpret_cast<const uint8_t*>(data.data()), data.size()));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Harnesses, FuzzCorpus,
    ::testing::Values(Harness{"obj", fuzz::run_obj}, Harness{"mgf", fuzz::run_mgf},
                      Harness{"toml", fuzz::run_toml}, Harness{"merge", fuzz::run_merge}),
    [](const ::testing::TestParamInfo<Harness>& p) { return std::string(p.param.name); });

}  // namespace
}  // namespace radlab
