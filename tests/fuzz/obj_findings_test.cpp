// The OBJ fuzz findings of 2026-11-28 (fuzz/corpus/obj/finding_*, docs/reliability.md), checked
// for what went wrong in each group beyond the corpus replay's "read or refused cleanly":
// - finding_area_*: scenes near the 1e12 m coordinate limit whose area account did not balance
//   against a tolerance taken relative to the area read; it must balance within the rounding of
//   the magnitudes it adds up (AreaAccount::rounding);
// - finding_slow_*: scenes of 1-4 kB on which the coincident-overlap repair cut one triangle into
//   663,552 rounding slivers (30-40 s per load); the pieces kept must stay few. An operation
//   count, not a clock: the scenes have at most 150 faces.
// (finding_cgal_*, undefined behaviour inside CGAL, is what the sanitizer build's replay and
// tests/scene/triangulate_test.cpp check.)
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.h"
#include "fuzz/fuzz_support.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"

namespace radlab {
namespace {

// The finding's scene (OBJ, `#--8<--`, MTL) written the way fuzz::run_obj writes it, then loaded.
LoadedScene load_finding(const std::string& name) {
  const auto file = std::filesystem::path(RADLAB_SOURCE_DIR) / "fuzz" / "corpus" / "obj" / name;
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  const std::string data = text.str();
  const auto parts =
      fuzz::split_parts(reinterpret_cast<const uint8_t*>(data.data()), data.size(), 2);
  fuzz::clear_scratch();
  fuzz::write_file(fuzz::scratch() / "scene.obj", parts[0]);
  fuzz::write_file(fuzz::scratch() / "m.mtl", parts[1]);
  return load_scene((fuzz::scratch() / "scene.obj").string(), false);
}

std::vector<std::string> findings(const std::string& prefix) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(
           std::filesystem::path(RADLAB_SOURCE_DIR) / "fuzz" / "corpus" / "obj"))
    if (entry.path().filename().string().starts_with(prefix))
      names.push_back(entry.path().filename().string());
  return names;
}

TEST(ObjFindings, AreaAccountBalancesNearTheCoordinateLimit) {
  const auto names = findings("finding_area_");
  ASSERT_EQ(names.size(), 3u);
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const LoadedScene loaded = load_finding(name);
    const AreaAccount& area = loaded.report.area;
    EXPECT_TRUE(area.balanced()) << area.unaccounted() << " of " << area.read << " m^2";
    for (const std::string& w : loaded.report.warnings)
      EXPECT_EQ(w.find("please report this as a bug"), std::string::npos) << w;
  }
}

TEST(ObjFindings, OverlapRepairKeepsFewPieces) {
  const auto names = findings("finding_slow_");
  ASSERT_EQ(names.size(), 9u);
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    LoadedScene loaded;
    try {
      loaded = load_finding(name);
    } catch (const Error&) {
      continue;  // refused with a message (kMaxRepairPieces): bounded too
    }
    // At most 150 faces, each split into a few triangles and cut by the repair into a few
    // convex pieces: 2,000 is ten times what any of the nine keeps now (69-139) and 300 times
    // below the 663,552 slivers one triangle became before.
    EXPECT_LE(loaded.scene.polygons.size(), 2000u);
    EXPECT_TRUE(loaded.report.area.balanced());
  }
}

}  // namespace
}  // namespace radlab
