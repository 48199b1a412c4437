#include "experiments/run/version_info.h"

#include <OpenEXR/OpenEXRConfig.h>
#include <ceres/version.h>
#include <embree3/rtcore_config.h>
#include <png.h>
#include <tbb/version.h>
#include <toml++/toml.h>

#include <Eigen/Core>
#include <glm/detail/setup.hpp>
#include <nlohmann/json.hpp>

#include "core/version.h"
#include "experiments/run/outputs.h"

namespace radlab {

namespace {

std::string dotted(int major, int minor, int patch) {
  return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
}

}  // namespace

std::vector<std::pair<std::string, std::string>> dependency_versions() {
  return {
      {"Embree", RTC_VERSION_STRING},
      {"oneTBB", std::string(TBB_VERSION_STRING) + " (run time " + TBB_runtime_version() + ")"},
      {"OpenEXR", OPENEXR_VERSION_STRING},
      {"libpng", PNG_LIBPNG_VER_STRING},
      {"Ceres", CERES_VERSION_STRING},
      {"Eigen", dotted(EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
      {"glm", dotted(GLM_VERSION_MAJOR, GLM_VERSION_MINOR, GLM_VERSION_PATCH)},
      {"nlohmann-json", dotted(NLOHMANN_JSON_VERSION_MAJOR, NLOHMANN_JSON_VERSION_MINOR,
                               NLOHMANN_JSON_VERSION_PATCH)},
      {"toml++", dotted(TOML_LIB_MAJOR, TOML_LIB_MINOR, TOML_LIB_PATCH)},
  };
}

std::string version_text() {
  std::string out = std::string("radlab ") + kVersion + " (git " + build_git_sha() + ")\n";
  out += std::string("compiler: ") +
#if defined(__clang__)
         "clang++ " +
#else
         "g++ " +
#endif
         __VERSION__ + "\n";
  for (const auto& [name, version] : dependency_versions()) out += name + ": " + version + "\n";
  return out;
}

}  // namespace radlab
