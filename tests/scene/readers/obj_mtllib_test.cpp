// OBJ `mtllib` confinement (issue 36.4): `mtllib ../../etc/passwd` or an absolute path made
// radlab parse any file as a material library and print the first 24 characters of every line
// as "unknown MTL statement" warnings. Material libraries now resolve inside the OBJ's folder
// (or the include root, --mgf-include-root, as MGF includes do), a library must begin with
// `newmtl`, and at most a few printable characters of a word radlab does not understand are
// shown.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "scene/readers/obj_reader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::expect_error;
using testing::TempDir;

const char* kSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl lamp\nf 1 2 3 4\n";
const char* kLampMtl = "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
// A file that is not a material library, with secrets in its first words.
const char* kSecrets = "root:$6$SECRETHASHVALUE:19000:0:99999:7:::\nadmin:TOPSECRETPASSWORD\n";

std::string scene_in(const TempDir& dir, const std::string& folder, const std::string& mtllib) {
  std::filesystem::create_directories(dir.path() / folder);
  return dir.write(folder + "/s.obj", "mtllib " + mtllib + "\n" + kSquare);
}

TEST(ObjMtllib, LibraryOutsideTheSceneFolderIsRefused) {
  TempDir dir;
  dir.write("lamp.mtl", kLampMtl);
  const std::string obj = scene_in(dir, "scene", "../lamp.mtl");
  expect_error<InputError>([&] { read_obj(obj); },
                           {"s.obj:1", "outside the scene's folder", "--mgf-include-root"});
  // An absolute name is confined the same way.
  const std::string absolute = scene_in(dir, "other", dir.file("lamp.mtl"));
  expect_error<InputError>([&] { read_obj(absolute); }, {"s.obj:1", "outside"});
}

TEST(ObjMtllib, TheIncludeRootAdmitsAFolderThatHoldsBoth) {
  TempDir dir;
  dir.write("lamp.mtl", kLampMtl);
  const std::string obj = scene_in(dir, "scene", "../lamp.mtl");
  ObjOptions options;
  options.include_root = dir.path().string();
  const Scene scene = read_obj(obj, options);
  ASSERT_EQ(scene.materials.size(), 1u);
  EXPECT_EQ(scene.materials[0].emission, Rgb(1.0));
}

TEST(ObjMtllib, AFileThatIsNotAMaterialLibraryIsRefusedWithoutShowingIt) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "scene");
  dir.write("scene/shadow", kSecrets);
  const std::string obj = scene_in(dir, "scene", "shadow");
  ::testing::internal::CaptureStderr();
  try {
    read_obj(obj);
    ADD_FAILURE() << "expected an error";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("shadow:1"), std::string::npos) << message;
    EXPECT_NE(message.find("not a material library"), std::string::npos) << message;
    EXPECT_EQ(message.find("SECRET"), std::string::npos) << message;
    EXPECT_EQ(message.find("root:"), std::string::npos) << message;
  }
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(printed.find("SECRET"), std::string::npos) << printed;
}

TEST(ObjMtllib, UnknownStatementsShowAFewPrintableCharacters) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "scene");
  dir.write("scene/m.mtl", std::string(kLampMtl) + "TOPSECRETPASSWORD123 x\nBAD\x01KEY 1\n");
  const std::string obj = scene_in(dir, "scene", "m.mtl");
  ::testing::internal::CaptureStderr();
  read_obj(obj);
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(printed.find("m.mtl:4: unknown MTL statement 'TOPSECRETPAS...'"), std::string::npos)
      << printed;
  EXPECT_EQ(printed.find("PASSWORD"), std::string::npos) << printed;
  EXPECT_NE(printed.find("'BAD?KEY'"), std::string::npos) << printed;
}

}  // namespace
}  // namespace radlab
