// Helpers shared by the tests: scenes made of given polygons, temporary folders, tolerances.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

#include "scene/mesh.h"
#include "scene/scene.h"

namespace radlab::testing {

// A scene with one material (reflectance rho, emission e) and the given polygons.
Scene scene_of(const std::vector<std::vector<Vec3>>& polygons, double rho = 0.5, double e = 1.0);

// Unit square [0,1]^2 in the plane z = height, front side facing +z (up) or -z (down).
std::vector<Vec3> square_z(double height, bool facing_up);

// A fresh empty folder under the system's temporary directory, removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes `contents` to a file in the folder and returns its path.
  std::string write(const std::string& name, const std::string& contents) const;

 private:
  std::filesystem::path path_;
};

// Expects `fn` to throw E whose message contains every one of `parts`.
template <class E, class Fn>
void expect_error(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    FAIL() << "expected an error";
  } catch (const E& e) {
    for (const std::string& part : parts)
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "message '" << e.what() << "' lacks '" << part << "'";
  }
}

// A command line's exit code and its stdout and stderr together.
struct CommandResult {
  int code = -1;  // -1 when it did not exit normally (killed by a signal) or could not start
  std::string output;
};
// Runs `shell_command` through sh, stderr into stdout.
CommandResult run_command(const std::string& shell_command);

// True when the environment says CI=true (as GitHub Actions, GitLab CI and others set it).
bool ci();

// The shared scene `relative` (e.g. "renderpark/examp1.mgf") under RADLAB_SHARED_SCENES, or empty
// with `missing` saying why (the variable unset, or no such file): for RADLAB_SHARED_MISSING.
std::string shared_scene(const std::string& relative, std::string& missing);

}  // namespace radlab::testing

// For a test that needs the shared scenes (../shared, RADLAB_SHARED_SCENES) when they are
// missing: skips on a developer's clone without them, but fails under CI=true, where a green run
// must not come from skipped tests. `what` may stream: RADLAB_SHARED_MISSING(path << " missing").
#define RADLAB_SHARED_MISSING(what)                                                    \
  if (::radlab::testing::ci())                                                         \
    GTEST_FAIL() << what << " (CI=true: the shared scenes are required, not skipped)"; \
  else                                                                                 \
    GTEST_SKIP() << what

namespace radlab::testing {}  // namespace radlab::testing
