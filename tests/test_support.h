// Helpers shared by the tests: scenes made of given polygons, temporary folders, tolerances.
#pragma once

#include <filesystem>
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

}  // namespace radlab::testing
