// `--limits polygons=N` on OBJ input (issue 36.7): MGF counted its polygons against the limit,
// OBJ did not (`--limits polygons=100` accepted 900 faces; a 77 MB OBJ of 10^7 faces cost 110 s
// and 4.5 GB). The faces are counted in one pass over the bytes before any is parsed.
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "core/limits.h"
#include "scene/readers/obj_reader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::expect_error;
using testing::TempDir;

// `faces` triangles on three vertices, then `tail`.
std::string triangles(int faces, const std::string& tail = "") {
  std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < faces; ++i) obj += (i % 2 ? "f 1 2 3\n" : "  f\t1 2 3\n");
  return obj + tail;
}

class ObjPolygonLimit : public ::testing::Test {
 protected:
  void SetUp() override { limits().polygons = 100; }
  void TearDown() override { limits().polygons = saved_; }
  const double saved_ = limits().polygons;
};

TEST_F(ObjPolygonLimit, AtTheLimitLoads) {
  TempDir dir;
  EXPECT_EQ(read_obj(dir.write("s.obj", triangles(100))).polygons.size(), 100u);
}

TEST_F(ObjPolygonLimit, AboveTheLimitIsRefusedNamingTheFileAndTheKey) {
  TempDir dir;
  expect_error<InputError>([&] { read_obj(dir.write("s.obj", triangles(101))); },
                           {"s.obj", "101", "polygons", "--limits"});
}

TEST_F(ObjPolygonLimit, CountedBeforeAnyFaceIsParsed) {
  // A malformed statement after the 101 faces: the limit is what is reported, so the refusal
  // came before the parser reached it (reading stops at the limit, not at the end).
  TempDir dir;
  const std::string obj = dir.write("s.obj", triangles(101, "bogus statement\n"));
  expect_error<InputError>([&] { read_obj(obj); }, {"polygons", "--limits"});
}

TEST_F(ObjPolygonLimit, OnlyFaceStatementsCount) {
  // Comments, 'fo' words and other statements are not faces.
  TempDir dir;
  const std::string obj = dir.write("s.obj", triangles(100, "# f 1 2 3\ng foo\no f\n"));
  EXPECT_EQ(read_obj(obj).polygons.size(), 100u);
}

}  // namespace
}  // namespace radlab
