// Loading solver plugins (solvers/plugin_loader.h): every way a plugin can be wrong
// gives a message naming the file and exit 2 (the path) or 3 (the file), never a crash. The working
// plugin (examples/southwell_plugin, built against the installed package) is exercised by the
// ctest plugin.installed_package (tests/PluginPackageTest.cmake).
#include "solvers/plugin_loader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/error.h"
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

// ---- the contract, loader side (issue 36.6): plugins load only where solvers are used, so one
// bad .so does not break `radlab scenes`; relative RADLAB_PLUGIN_PATH entries are refused; a
// folder entry does not follow links to other places; each loaded file's SHA-256 is recorded.

TEST(PluginContract, ABadPluginDoesNotBreakACommandThatRunsNoSolver) {
  TempDir dir;
  const std::string fake = dir.write("fake.so", "not an ELF file\n");
  const CommandResult scenes = radlab("--plugin " + fake + " scenes builtin:cube");
  EXPECT_EQ(scenes.code, 0) << scenes.output;
  const CommandResult env = radlab("scenes builtin:cube", "RADLAB_PLUGIN_PATH=" + fake);
  EXPECT_EQ(env.code, 0) << env.output;
  // Where solvers are used it is still refused, naming the file.
  const CommandResult solvers = radlab("--plugin " + fake + " solvers");
  EXPECT_EQ(solvers.code, 3) << solvers.output;
  EXPECT_OUTPUT_HAS(solvers, "fake.so");
}

TEST(PluginContract, RelativePluginPathEntriesAreRefused) {
  const CommandResult r = radlab("solvers", "RADLAB_PLUGIN_PATH=plugins/here.so");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_OUTPUT_HAS(r, "RADLAB_PLUGIN_PATH: 'plugins/here.so' is a relative path");
}

TEST(PluginContract, AFolderEntryDoesNotFollowLinksElsewhere) {
  // A link in the folder to a plugin outside it (one that would be refused if loaded: its ABI
  // differs) is skipped with a warning; the command succeeds.
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "plugins");
  std::filesystem::create_symlink(BAD_ABI_PLUGIN, dir.path() / "plugins" / "elsewhere.so");
  const CommandResult r = radlab("solvers", "RADLAB_PLUGIN_PATH=" + dir.file("plugins"));
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_OUTPUT_HAS(r, "elsewhere.so skipped");
  // Named by its own path, the same file is loaded (and refused for its ABI).
  const CommandResult named =
      radlab("solvers", std::string("RADLAB_PLUGIN_PATH=") + BAD_ABI_PLUGIN);
  EXPECT_EQ(named.code, 3) << named.output;
}

TEST(PluginContract, FileSha256IsTheStandardDigest) {
  // FIPS 180-2's examples: "abc" and the empty message.
  TempDir dir;
  EXPECT_EQ(file_sha256(dir.write("abc", "abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(file_sha256(dir.write("empty", "")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_THROW(file_sha256(dir.file("missing")), InputError);
}

}  // namespace
}  // namespace radlab
