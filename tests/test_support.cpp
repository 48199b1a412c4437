#include "tests/test_support.h"

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>

namespace radlab::testing {

Scene scene_of(const std::vector<std::vector<Vec3>>& polygons, double rho, double e) {
  Scene scene;
  scene.name = "test";
  scene.materials.push_back(Material{"m", Rgb(rho), Rgb(e)});
  int k = 0;
  for (const auto& p : polygons) scene.polygons.push_back(Polygon{p, 0, "p" + std::to_string(k++)});
  return scene;
}

std::vector<Vec3> square_z(double h, bool up) {
  std::vector<Vec3> v = {{0, 0, h}, {1, 0, h}, {1, 1, h}, {0, 1, h}};
  if (!up) std::reverse(v.begin(), v.end());
  return v;
}

TempDir::TempDir() {
  std::random_device rd;
  path_ = std::filesystem::temp_directory_path() /
          ("radlab-test-" + std::to_string(rd()) + std::to_string(rd()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string TempDir::write(const std::string& name, const std::string& contents) const {
  std::string p = file(name);
  std::ofstream(p) << contents;
  return p;
}

CommandResult run_command(const std::string& shell_command) {
  CommandResult r;
  FILE* pipe = popen(("(" + shell_command + ") 2>&1").c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer;
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) r.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool ci() {
  const char* value = std::getenv("CI");
  return value && std::string(value) == "true";
}

std::string shared_scene(const std::string& relative, std::string& missing) {
  const char* root = std::getenv("RADLAB_SHARED_SCENES");
  if (!root || !*root) {
    missing = "RADLAB_SHARED_SCENES is not set";
    return {};
  }
  const std::string path = std::string(root) + "/" + relative;
  if (!std::ifstream(path)) {
    missing = path + " is missing";
    return {};
  }
  return path;
}

}  // namespace radlab::testing
