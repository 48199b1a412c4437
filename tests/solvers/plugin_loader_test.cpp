// Loading solver plugins (solvers/plugin_loader.h): every way a plugin can be wrong
// gives a message naming the file and exit 2 (the path) or 3 (the file), never a crash. The working
// plugin (examples/southwell_plugin, built against the installed package) is exercised by the
// ctest plugin.installed_package (tests/PluginPackageTest.cmake).
#include <gtest/gtest.h>

#include <string>

#include "tests/test_support.h"

namespace radlab {
namespace {

using radlab::testing::CommandResult;
using radlab::testing::TempDir;

CommandResult radlab(const std::string& arguments, const std::string& environment = "") {
  return radlab::testing::run_command(environment + " timeout 120 " + RADLAB_BINARY + " " +
                                      arguments);
}

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

TEST(Plugin, MissingFileIsAUsageError) {
  const CommandResult r = radlab("--plugin /no/such/plugin.so solvers");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_OUTPUT_HAS(r, "/no/such/plugin.so: no such file");
  const CommandResult env = radlab("solvers", "RADLAB_PLUGIN_PATH=/no/such/folder");
  EXPECT_EQ(env.code, 2) << env.output;
  EXPECT_OUTPUT_HAS(env, "RADLAB_PLUGIN_PATH: '/no/such/folder' does not exist");
}

TEST(Plugin, NotALibraryIsInvalidInput) {
  TempDir dir;
  const std::string path = dir.write("fake.so", "not an ELF file\n");
  const CommandResult r = radlab("--plugin " + path + " solvers");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "cannot be loaded");
}

TEST(Plugin, ALibraryWithoutThePluginSymbolsIsRefused) {
  const CommandResult r = radlab("--plugin /usr/lib/x86_64-linux-gnu/libpng16.so.16 solvers");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "not a radlab plugin");
}

TEST(Plugin, AnotherAbiIsRefusedBeforeItRuns) {
  const CommandResult r = radlab(std::string("--plugin ") + BAD_ABI_PLUGIN + " solvers");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "plugin ABI");
  EXPECT_OUTPUT_HAS(r, "rebuild it against this radlab");
}

TEST(Plugin, ADuplicateNameIsRefused) {
  const CommandResult r = radlab(std::string("--plugin ") + DUPLICATE_PLUGIN + " solvers");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "a solver named 'jacobi' is registered already");
  EXPECT_OUTPUT_HAS(r, DUPLICATE_PLUGIN);
}

TEST(Plugin, ParametersThatDifferFromTheOptionsAreRefused) {
  const CommandResult r = radlab(std::string("--plugin ") + UNDOCUMENTED_PLUGIN + " solvers");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "key 'omega' is read but not listed");
}

}  // namespace
}  // namespace radlab
