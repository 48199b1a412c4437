// Every file a scene reads is recorded with the SHA-256 of its bytes (Scene::sources), where the
// data enters: the OBJ and each material library it names, the MGF file and each include. A
// sweep's identity is built from these (issue 36.2), so a list that missed a file would let an
// edit of that file mix two scene versions in one sweep.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/sha256.h"
#include "scene/scene_loader.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

TEST(SceneSources, Sha256IsTheStandardDigest) {
  // FIPS 180-2's test vector "abc" and the empty string: what sha256sum prints.
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(SceneSources, AnObjAndItsMaterialLibraryAreBothRecorded) {
  TempDir dir;
  const std::string obj = dir.write("box.obj", testing::kBoxObj);
  const std::string mtl = dir.write("box.mtl", testing::kBoxMtl);
  const LoadedScene loaded = load_scene(obj, false);
  ASSERT_EQ(loaded.scene.sources.size(), 2u);
  EXPECT_EQ(loaded.scene.sources[0], (SourceFile{obj, file_sha256(obj)}));
  EXPECT_EQ(std::filesystem::path(loaded.scene.sources[1].path), std::filesystem::path(mtl));
  EXPECT_EQ(loaded.scene.sources[1].sha256, file_sha256(mtl));
  // The identity reader (no validation) lists the same, and an edit of the library shows.
  EXPECT_EQ(scene_source_files(obj), loaded.scene.sources);
  dir.write("box.mtl", std::string(testing::kBoxMtl) + "# edited\n");
  EXPECT_NE(scene_source_files(obj)[1].sha256, loaded.scene.sources[1].sha256);
  // A file without a final newline is hashed as its bytes, not as lines.
  dir.write("box.mtl", "newmtl white\nKd 0.5 0.5 0.5\nnewmtl light\nKe 1 1 1");
  EXPECT_EQ(scene_source_files(obj)[1].sha256, file_sha256(mtl));
}

TEST(SceneSources, AnMgfFileAndItsIncludesAreRecordedOnceEach) {
  TempDir dir;
  const std::string quad = R"(v a =
p 0 0 0
v b =
p 1 0 0
v c =
p 1 1 0
v d =
p 0 1 0
m lamp =
ed 10
f a b c d
)";
  const std::string inc = dir.write("inc.mgf", quad);
  const std::string main = dir.write("main.mgf", "i inc.mgf\ni inc.mgf -t 0 0 1\n");
  const auto sources = scene_source_files(main);
  ASSERT_EQ(sources.size(), 2u);
  EXPECT_EQ(sources[0], (SourceFile{main, file_sha256(main)}));
  EXPECT_EQ(std::filesystem::path(sources[1].path).lexically_normal(),
            std::filesystem::path(inc).lexically_normal());
  EXPECT_EQ(sources[1].sha256, file_sha256(inc));
  EXPECT_TRUE(scene_source_files("builtin:cube").empty());
}

}  // namespace
}  // namespace radlab
