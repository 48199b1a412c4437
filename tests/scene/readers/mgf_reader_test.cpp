// MGF input: small inline files for every entity the reader supports (materials, colours,
// transforms and arrays, includes, each curved primitive's area and orientation, errors with
// file:line), the CIE colour conversion, and every shared RenderPark scene with the counts
// docs/scenes.md states.
#include "scene/readers/mgf_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>

#include "core/error.h"
#include "scene/cie_colour.h"
#include "scene/geometry.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;
constexpr double kPi = std::numbers::pi;

using testing::expect_error;

MgfOptions quiet() {
  MgfOptions options;
  options.print_warnings = false;
  return options;
}

// Reads MGF text written to a temporary file.
Scene read(const std::string& text, MgfStats* stats = nullptr, MgfOptions options = quiet()) {
  TempDir dir;
  return read_mgf(dir.write("s.mgf", text), options, stats);
}

const char* kSquare =  // unit square in z = 0, counter-clockwise seen from +z
    "v a =\n p 0 0 0\nv b =\n p 1 0 0\nv c =\n p 1 1 0\nv d =\n p 0 1 0\n";

const Material& material_of(const Scene& s, size_t polygon) {
  return s.materials.at(size_t(s.polygons.at(polygon).material));
}

double total_area(const Scene& s) {
  double a = 0.0;
  for (const Polygon& p : s.polygons) a += geometry::area(p.vertices);
  return a;
}

// ---- colour ---------------------------------------------------------------------------------

TEST(CieColour, RgbSpaceHasRec709PrimariesAndEqualEnergyWhite) {
  EXPECT_NEAR(cie::luminance(Rgb(1.0)), 1.0, 1e-12);
  const cie::Chromaticity white = cie::chromaticity(cie::rgb_to_xyz(Rgb(1.0)));
  EXPECT_NEAR(white.x, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(white.y, 1.0 / 3.0, 1e-12);
  const cie::Chromaticity red = cie::chromaticity(cie::rgb_to_xyz(Rgb(1, 0, 0)));
  EXPECT_NEAR(red.x, 0.64, 1e-12);
  EXPECT_NEAR(red.y, 0.33, 1e-12);
  const cie::Chromaticity green = cie::chromaticity(cie::rgb_to_xyz(Rgb(0, 1, 0)));
  EXPECT_NEAR(green.x, 0.30, 1e-12);
  EXPECT_NEAR(green.y, 0.60, 1e-12);
  const Rgb v(0.2, 0.5, 0.9);
  const Rgb back = cie::xyz_to_rgb(cie::rgb_to_xyz(v));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], v[k], 1e-12);
}

TEST(CieColour, ColourMatchingFunctionsFollowTheCie1931Observer) {
  // Peaks of the tabulated CIE 1931 functions; the analytic fit is within about 1% of them.
  EXPECT_NEAR(cie::colour_matching(555).y, 1.0, 0.02);
  EXPECT_NEAR(cie::colour_matching(600).x, 1.0622, 0.03);
  EXPECT_NEAR(cie::colour_matching(445).z, 1.7826, 0.05);
  // The equal-energy spectrum is the neutral (1/3, 1/3) exactly (by construction).
  const double flat[] = {1.0, 1.0};
  const cie::Chromaticity e = cie::chromaticity(cie::spectrum_to_xyz(380, 780, flat));
  EXPECT_NEAR(e.x, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.y, 1.0 / 3.0, 1e-12);
}

TEST(CieColour, BlackbodyChromaticityFollowsThePlanckianLocus) {
  // CIE 1931 chromaticities of black bodies (standard tables), within the fit's accuracy.
  const cie::Chromaticity a = cie::chromaticity(cie::blackbody_to_xyz(2856));  // illuminant A
  EXPECT_NEAR(a.x, 0.4476, 0.004);
  EXPECT_NEAR(a.y, 0.4074, 0.004);
  const cie::Chromaticity d = cie::chromaticity(cie::blackbody_to_xyz(6500));
  EXPECT_NEAR(d.x, 0.3135, 0.004);
  EXPECT_NEAR(d.y, 0.3237, 0.004);
}

// ---- materials and colours ------------------------------------------------------------------

TEST(MgfMaterials, NeutralColourGivesGreyReflectanceAndEmission) {
  Scene s =
      read(std::string(kSquare) + "m white =\n c\n  cxy .333 .333\n rd .7\n ed 100\n f a b c d\n");
  ASSERT_EQ(s.polygons.size(), 1u);
  EXPECT_EQ(material_of(s, 0).name, "white");
  EXPECT_EQ(material_of(s, 0).reflectance, Rgb(0.7));
  EXPECT_EQ(material_of(s, 0).emission, Rgb(100.0));
  EXPECT_TRUE(s.is_grey());
  EXPECT_NE(s.polygons[0].origin.find("s.mgf:"), std::string::npos);
}

TEST(MgfMaterials, ChromaticityAndLuminanceBecomeRgb) {
  // The RGB space's red primary at luminance 0.2: pure red, luminance kept.
  Scene s = read(std::string(kSquare) + "m red =\n c\n  cxy .64 .33\n rd .2\nf a b c d\n");
  const Rgb rho = material_of(s, 0).reflectance;
  EXPECT_GT(rho.x, 0.2);
  EXPECT_NEAR(rho.y, 0.0, 1e-9);
  EXPECT_NEAR(rho.z, 0.0, 1e-9);
  EXPECT_NEAR(cie::luminance(rho), 0.2, 1e-12);
  EXPECT_FALSE(s.is_grey());
}

TEST(MgfMaterials, OutOfGamutColoursAreDesaturatedKeepingLuminance) {
  MgfStats stats;
  // corridor.mgf's green (0, 0.38) lies outside the spectral locus; blokken2.mgf's purple
  // (0.4, 0) has y = 0.
  Scene s = read(std::string(kSquare) +
                     "m g =\n c\n  cxy 0 .38\n rd .12\nf a b c d\n"
                     "m p =\n c\n  cxy .4 0\n rd .2\n ed 50\nf a b c d\n",
                 &stats);
  EXPECT_EQ(stats.out_of_gamut, 2);
  EXPECT_EQ(stats.warnings.size(), 2u);
  const Material& g = material_of(s, 0);
  const Material& p = material_of(s, 1);
  EXPECT_NEAR(cie::luminance(g.reflectance), 0.12, 1e-12);
  EXPECT_NEAR(cie::luminance(p.reflectance), 0.2, 1e-12);
  EXPECT_NEAR(cie::luminance(p.emission), 50.0, 1e-9);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(g.reflectance[k], 0.0);
    EXPECT_LE(g.reflectance[k], 1.0);
    EXPECT_GE(p.reflectance[k], 0.0);
  }
  EXPECT_GT(g.reflectance.y, g.reflectance.x);  // still green
  EXPECT_NEAR(std::min({g.reflectance.x, g.reflectance.y, g.reflectance.z}), 0.0, 1e-12);
}

TEST(MgfMaterials, SpectraTemperaturesAndMixturesGiveChromaticities) {
  Scene s = read(std::string(kSquare) +
                 // A flat spectrum is neutral: exactly grey.
                 "m flat =\n c\n  cspec 400 700 2 2 2 2\n rd .5\nf a b c d\n"
                 // A 3000 K lamp is warm: red > green > blue, luminance = ed.
                 "m lamp =\n c\n  cct 3000\n ed 1000\nf a b c d\n"
                 // Equal-luminance mix of red and green primaries, then rd.
                 "c r =\n cxy .64 .33\nc g =\n cxy .30 .60\n"
                 "m mix =\n c\n  cmix 1 r 1 g\n rd .4\nf a b c d\n");
  EXPECT_EQ(material_of(s, 0).reflectance, Rgb(0.5));
  const Rgb e = material_of(s, 1).emission;
  EXPECT_GT(e.x, e.y);
  EXPECT_GT(e.y, e.z);
  EXPECT_NEAR(cie::luminance(e), 1000.0, 1e-9);
  const Rgb m = material_of(s, 2).reflectance;
  EXPECT_NEAR(m.z, 0.0, 1e-9);
  EXPECT_NEAR(cie::luminance(m), 0.4, 1e-12);
  // Luminance weights: red and green contribute 0.2 each.
  EXPECT_NEAR(cie::luminance(Rgb(m.x, 0, 0)), 0.2, 1e-9);
}

TEST(MgfMaterials, ContextsFollowMgfRules) {
  Scene s = read(std::string(kSquare) +
                 // Before any m: the unnamed material, a black absorber.
                 "f a b c d\n"
                 "m base =\n c\n rd .5\n"
                 // A template copy, then a change to the copy only.
                 "m copy = base\n rd .25\n"
                 "m base\nf a b c d\n"
                 "m copy\nf a b c d\n"
                 // Changing a material after use: earlier faces keep the old values.
                 "m base\n rd .125\nf a b c d\n"
                 // Named colour defined, selected later; specular and other terms are ignored.
                 "c warm =\n cxy .4 .4\nm w =\n c warm\n rd .3\n rs .1 .02\n ts .2 0\n sides 1\n"
                 " ir 1.5 0\n td .1\nf a b c d\n");
  ASSERT_EQ(s.polygons.size(), 5u);
  EXPECT_EQ(material_of(s, 0).reflectance, Rgb(0.0));
  EXPECT_EQ(material_of(s, 1).reflectance, Rgb(0.5));
  EXPECT_EQ(material_of(s, 2).reflectance, Rgb(0.25));
  EXPECT_EQ(material_of(s, 3).reflectance, Rgb(0.125));
  EXPECT_EQ(material_of(s, 3).name, "base #2");
  EXPECT_NEAR(cie::luminance(material_of(s, 4).reflectance), 0.3, 1e-12);  // rs not added
}

// ---- vertices and transforms ----------------------------------------------------------------

Vec3 first_vertex(const Scene& s, size_t polygon) {
  return s.polygons.at(polygon).vertices[0];
}

void expect_near(const Vec3& a, const Vec3& b, double tolerance = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

TEST(MgfTransforms, ArgumentsApplyInOrderAndInnerContextsFirst) {
  const std::string tri = "v o =\n p 0 0 0\nv x =\n p 1 0 0\nv y =\n p 0 1 0\n";
  Scene s = read(tri +
                 "xf -t 1 0 0 -rz 90\nf o x y\nxf\n"           // translate, then rotate: (0, 1, 0)
                 "xf -rz 90 -t 1 0 0\nf o x y\nxf\n"           // rotate, then translate: (1, 0, 0)
                 "xf -s 2\nxf -t 1 0 0\nf o x y\nxf\nxf\n"     // inner first: (2, 0, 0)
                 "xf -rx 90\nf o x y\nxf\n"                    // y -> z
                 "xf -ry 90\nf o x y\nxf\n"                    // x -> -z
                 "xf -t 1 2 3 -i 2 -t 1 0 0\nf o x y\nxf\n");  // -i 2: twice, (3, 2, 3)
  expect_near(first_vertex(s, 0), {0, 1, 0});
  expect_near(first_vertex(s, 1), {1, 0, 0});
  expect_near(first_vertex(s, 2), {2, 0, 0});
  expect_near(s.polygons[3].vertices[2], {0, 0, 1});
  expect_near(s.polygons[4].vertices[1], {0, 0, -1});
  expect_near(first_vertex(s, 5), {3, 2, 3});
}

TEST(MgfTransforms, MirrorsKeepTheFrontSide) {
  // A mirror reverses the winding so the mirrored square still faces +z, as MGF's parser does.
  Scene s =
      read(std::string(kSquare) + "f a b c d\nxf -mx\nf a b c d\nxf\nxf -s -1\nf a b c d\nxf\n");
  ASSERT_EQ(s.polygons.size(), 3u);
  EXPECT_NEAR(geometry::unit_normal(s.polygons[1].vertices).z, 1.0, 1e-12);
  EXPECT_NEAR(geometry::centroid(s.polygons[1].vertices).x, -0.5, 1e-12);
  // -s -1 is a point reflection: the square moves to z = 0, x, y < 0 and faces -z.
  EXPECT_NEAR(geometry::unit_normal(s.polygons[2].vertices).z, -1.0, 1e-12);
}

TEST(MgfTransforms, ArraysReplicateTheEnclosedEntitiesFirstIndexFastest) {
  Scene s = read(std::string(kSquare) +
                 "xf -t 10 0 0 -a 3 -t 1 0 0 -a 2 -t 0 5 0\n"
                 // Entities inside an array run once per instance, nested contexts included.
                 "o cell\nxf -s 0.5\nf a b c d\nxf\no\n"
                 "xf\n"
                 "f a b c d\n");
  ASSERT_EQ(s.polygons.size(), 7u);
  const Vec3 expected[] = {{10, 0, 0}, {11, 0, 0}, {12, 0, 0}, {10, 5, 0}, {11, 5, 0}, {12, 5, 0}};
  for (size_t i = 0; i < 6; ++i) {
    expect_near(first_vertex(s, i), expected[i]);
    EXPECT_NEAR(geometry::area(s.polygons[i].vertices), 0.25, 1e-12);
  }
  expect_near(first_vertex(s, 6), {0, 0, 0});  // the array's context is closed
}

TEST(MgfTransforms, ArrayWithMirrorLikeExamp1) {
  // examp1.mgf: `xf -a 2 -my` gives the geometry and its mirror image.
  Scene s = read(
      "v a =\n p 0 1 0\nv b =\n p 1 1 0\nv c =\n p 1 2 0\n"
      "xf -a 2 -my\nf a b c\nxf\n");
  ASSERT_EQ(s.polygons.size(), 2u);
  EXPECT_NEAR(geometry::centroid(s.polygons[1].vertices).y,
              -geometry::centroid(s.polygons[0].vertices).y, 1e-12);
  EXPECT_NEAR(geometry::unit_normal(s.polygons[1].vertices).z, 1.0, 1e-12);
}

TEST(MgfVertices, NamesAreGlobalAndALaterDefinitionReplacesAnEarlierOne) {
  // Vertices defined in one object and used in a sibling (what office1/graz.mgf does
  // throughout); positions are taken at the time of use, in the transform of the use.
  Scene s = read(
      "o first\nv a =\n p 0 0 0\nv b =\n p 1 0 0\no\n"
      "o second\nv c =\n p 0 1 0\nf a b c\n"
      "v a =\n p 0 0 1\nf a b c\n"
      "v b\n p 2 0 0\nf a b c\n"
      "v d = c\nxf -t 0 0 5\nf a b d\nxf\no\n");
  ASSERT_EQ(s.polygons.size(), 4u);
  expect_near(first_vertex(s, 0), {0, 0, 0});
  expect_near(first_vertex(s, 1), {0, 0, 1});
  expect_near(s.polygons[2].vertices[1], {2, 0, 0});
  expect_near(s.polygons[3].vertices[2], {0, 1, 5});
}

TEST(MgfSyntax, ContinuationLinesCommentsAndStrayLines) {
  MgfStats stats;
  Scene s = read(std::string(kSquare) +
                     "# a comment \\\n  continued as comment\n"
                     "f a b \\\n   c d\n"
                     "#tight comment\n"
                     "/usr/people/stray/path.rad\n",
                 &stats);
  ASSERT_EQ(s.polygons.size(), 1u);
  EXPECT_EQ(s.polygons[0].vertices.size(), 4u);
  EXPECT_NE(s.polygons[0].origin.find("s.mgf:11"), std::string::npos);
  EXPECT_EQ(stats.ignored_lines, 1);
  ASSERT_EQ(stats.warnings.size(), 1u);
  EXPECT_NE(stats.warnings[0].find("s.mgf:14"), std::string::npos);
  EXPECT_NE(stats.warnings[0].find("/usr/people/stray"), std::string::npos);
}

// ---- includes -------------------------------------------------------------------------------

TEST(MgfIncludes, RelativeToTheIncludingFileWithTransformsAndArrays) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "sub" / "parts");
  dir.write("sub/parts/square.mgf", std::string(kSquare) + "f a b c d\n");
  dir.write("sub/group.mgf", "i parts/square.mgf\ni ./parts/square.mgf -t 0 0 1\n");
  dir.write("sub/lib.mgf", "m red =\n c\n  cxy .64 .33\n rd .2\n");
  const std::string top = dir.write("top.mgf",
                                    "i sub/lib.mgf\nm red\n"
                                    "i sub/group.mgf -t 5 0 0\n"
                                    "i sub/parts/square.mgf -a 3 -t 0 2 0\n");
  MgfStats stats;
  Scene s = read_mgf(top, quiet(), &stats);
  ASSERT_EQ(s.polygons.size(), 5u);
  EXPECT_EQ(stats.files, 4);
  expect_near(first_vertex(s, 0), {5, 0, 0});
  expect_near(first_vertex(s, 1), {5, 0, 1});
  expect_near(first_vertex(s, 4), {0, 4, 0});
  EXPECT_EQ(material_of(s, 4).name, "red");  // materials defined in an include stay defined
  EXPECT_NE(s.polygons[0].origin.find("square.mgf:9"), std::string::npos);
}

TEST(MgfIncludes, MissingFilesAndCyclesAreErrorsWithTheIncludeChain) {
  TempDir dir;
  dir.write("inner.mgf", "i nosuch.mgf\n");
  const std::string outer = dir.write("outer.mgf", "# top\ni inner.mgf\n");
  expect_error<InputError>(
      [&] { read_mgf(outer, quiet()); },
      {"inner.mgf:1", "nosuch.mgf", "not found", "included from", "outer.mgf:2"});
  const std::string loop = dir.write("loop.mgf", "i loop.mgf\n");
  expect_error<InputError>([&] { read_mgf(loop, quiet()); }, {"loop.mgf:1", "nested"});
  // Contexts must balance within each file.
  dir.write("open.mgf", "xf -t 1 0 0\n");
  const std::string uses = dir.write("uses.mgf", "i open.mgf\n");
  expect_error<InputError>([&] { read_mgf(uses, quiet()); }, {"open.mgf:1", "not closed"});
}

// ---- curved primitives ----------------------------------------------------------------------

// Tessellated areas: every primitive's polygons are inscribed (vertices on the true surface),
// so the area is below the true one by a known factor; the tests check both the exact area of
// the inscribed polygons and its relative error against the analytic area.
constexpr int kN = 16;  // segments around at the default 4 per quarter circle
const double kChord = 2.0 * std::sin(kPi / kN);  // chord of a unit circle per segment
const double kApothem = std::cos(kPi / kN);

// Area of the band between two parallel circles (radius r0 at height z0, r1 at z1), inscribed.
double band_area(double r0, double z0, double r1, double z1) {
  return kN * 0.5 * kChord * (r0 + r1) * std::hypot(z1 - z0, (r1 - r0) * kApothem);
}

// Checks that every polygon faces away from (outward) or towards (inward) the nearest point of
// `axis_point(centroid)`.
template <class Fn>
void expect_facing(const Scene& s, Fn inside_point, bool outward) {
  for (const Polygon& p : s.polygons) {
    const Vec3 c = geometry::centroid(p.vertices);
    const double side = glm::dot(geometry::unit_normal(p.vertices), c - inside_point(c));
    EXPECT_TRUE(outward ? side > 0 : side < 0) << p.origin;
  }
}

TEST(MgfPrimitives, CylinderAndConeAreasAndOrientation) {
  const std::string axis = "v b =\n p 0 0 0\nv t =\n p 0 0 2\n";
  Scene cyl = read(axis + "cyl b 1 t\n");
  ASSERT_EQ(cyl.polygons.size(), size_t(kN));
  const double exact = kN * kChord * 2.0;
  EXPECT_NEAR(total_area(cyl), exact, 1e-12);
  EXPECT_NEAR(total_area(cyl) / (2 * kPi * 2.0) - 1.0, std::sin(kPi / kN) / (kPi / kN) - 1.0,
              1e-12);  // -0.64%
  auto on_axis = [](const Vec3& c) { return Vec3(0, 0, c.z); };
  expect_facing(cyl, on_axis, true);
  expect_facing(read(axis + "cyl b -1 t\n"), on_axis, false);

  Scene cone = read(axis + "cone b 1 t .5\n");
  EXPECT_NEAR(total_area(cone), band_area(1, 0, 0.5, 2), 1e-12);
  const double analytic = kPi * 1.5 * std::hypot(2.0, 0.5);
  EXPECT_NEAR(total_area(cone) / analytic, 1.0, 0.008);  // -0.76% here
  expect_facing(cone, on_axis, true);
  Scene tip = read(axis + "cone b 1 t 0\n");
  for (const Polygon& p : tip.polygons) EXPECT_EQ(p.vertices.size(), 3u);
  EXPECT_NEAR(total_area(tip), band_area(1, 0, 0, 2), 1e-12);
  expect_facing(read(axis + "cone b -1 t -.5\n"), on_axis, false);
}

TEST(MgfPrimitives, SphereAreaAndOrientation) {
  Scene s = read("v c =\n p 1 2 3\nsph c 2\n");
  ASSERT_EQ(s.polygons.size(), size_t(kN * kN / 2));  // 8 bands x 16
  double exact = 0.0;
  for (int j = 0; j < kN / 2; ++j) {
    const double a0 = kPi * j / (kN / 2), a1 = kPi * (j + 1) / (kN / 2);
    exact += band_area(2 * std::sin(a0), 2 * std::cos(a0), 2 * std::sin(a1), 2 * std::cos(a1));
  }
  EXPECT_NEAR(total_area(s), exact, 1e-9);
  EXPECT_NEAR(total_area(s) / (4 * kPi * 4) - 1.0, -0.0318, 0.0005);  // -3.2%
  auto centre = [](const Vec3&) { return Vec3(1, 2, 3); };
  expect_facing(s, centre, true);
  expect_facing(read("v c =\n p 1 2 3\nsph c -2\n"), centre, false);
  // Finer tessellation on request: 8 per quarter circle, error -0.8%.
  MgfOptions fine = quiet();
  fine.quarter_circle_divisions = 8;
  Scene f = read("v c =\n p 0 0 0\nsph c 1\n", nullptr, fine);
  EXPECT_EQ(f.polygons.size(), 32u * 16u);
  EXPECT_NEAR(total_area(f) / (4 * kPi), 1.0, 0.009);
}

TEST(MgfPrimitives, RingAndDiscFaceAlongTheCentreNormal) {
  Scene ring = read("v c =\n p 0 0 1\n n 0 0 -2\nring c .5 1\n");
  ASSERT_EQ(ring.polygons.size(), size_t(kN));
  const double inscribed = 0.5 * kN * std::sin(2 * kPi / kN);
  EXPECT_NEAR(total_area(ring), inscribed * (1.0 - 0.25), 1e-12);
  EXPECT_NEAR(total_area(ring) / (kPi * 0.75) - 1.0, -0.0255, 0.0005);  // -2.6%
  for (const Polygon& p : ring.polygons)
    EXPECT_NEAR(geometry::unit_normal(p.vertices).z, -1.0, 1e-12);
  Scene disc = read("v c =\n p 0 0 0\n n 1 0 0\nring c 0 2\n");
  for (const Polygon& p : disc.polygons) {
    EXPECT_EQ(p.vertices.size(), 3u);
    EXPECT_NEAR(geometry::unit_normal(p.vertices).x, 1.0, 1e-12);
  }
  EXPECT_NEAR(total_area(disc), inscribed * 4.0, 1e-12);
}

TEST(MgfPrimitives, TorusAreaAndOrientation) {
  Scene s = read("v c =\n p 0 0 0\n n 0 1 0\ntorus c 1 1.5\n");
  ASSERT_EQ(s.polygons.size(), size_t(kN * kN));
  const double big = 1.25, tube = 0.25;
  double exact = 0.0;
  for (int j = 0; j < kN; ++j) {
    const double a0 = 2 * kPi * j / kN, a1 = 2 * kPi * (j + 1) / kN;
    exact += band_area(big + tube * std::cos(a0), tube * std::sin(a0), big + tube * std::cos(a1),
                       tube * std::sin(a1));
  }
  EXPECT_NEAR(total_area(s), exact, 1e-12);
  EXPECT_NEAR(total_area(s) / (4 * kPi * kPi * big * tube) - 1.0, -0.0222, 0.0005);  // -2.2%
  // Outward: away from the tube's centre circle (radius 1.25 in the x-z plane).
  auto tube_centre = [&](const Vec3& c) {
    const Vec3 radial = glm::normalize(Vec3(c.x, 0, c.z));
    return big * radial;
  };
  expect_facing(s, tube_centre, true);
  expect_facing(read("v c =\n p 0 0 0\n n 0 1 0\ntorus c -1 -1.5\n"), tube_centre, false);
}

TEST(MgfPrimitives, PrismIsAClosedSolid) {
  // MGF's own example: the base faces -z, the prism extends to +z: the unit cube, outward.
  const std::string base = "v a =\n p 0 0 0\nv b =\n p 0 1 0\nv c =\n p 1 1 0\nv d =\n p 1 0 0\n";
  Scene s = read(base + "prism a b c d 1\n");
  ASSERT_EQ(s.polygons.size(), 6u);
  EXPECT_NEAR(total_area(s), 6.0, 1e-12);
  auto centre = [](const Vec3&) { return Vec3(0.5, 0.5, 0.5); };
  expect_facing(s, centre, true);
  // A negative length extrudes to the other side, faces inward.
  Scene in = read(base + "prism a b c d -1\n");
  expect_facing(
      in, [](const Vec3&) { return Vec3(0.5, 0.5, -0.5); }, false);
}

TEST(MgfPrimitives, ArgumentsAreChecked) {
  const std::string v = "v a =\n p 0 0 0\nv b =\n p 0 0 1\nv n =\n p 0 0 0\n n 0 0 1\n";
  expect_error<InputError>([&] { read(v + "cyl a 0 b\n"); }, {"s.mgf:8", "radius"});
  expect_error<InputError>([&] { read(v + "cone a 1 b -1\n"); }, {"s.mgf:8", "signs"});
  expect_error<InputError>([&] { read(v + "cyl a 1 a\n"); }, {"s.mgf:8", "coincide"});
  expect_error<InputError>([&] { read(v + "ring a 0 1\n"); }, {"s.mgf:8", "normal"});
  expect_error<InputError>([&] { read(v + "ring n 1 1\n"); }, {"s.mgf:8", "rmin < rmax"});
  expect_error<InputError>([&] { read(v + "torus n 1 -2\n"); }, {"s.mgf:8", "torus"});
  expect_error<InputError>([&] { read(v + "sph a 0\n"); }, {"s.mgf:8", "radius"});
}

// ---- errors ---------------------------------------------------------------------------------

TEST(MgfErrors, NameFileAndLine) {
  const std::string sq = kSquare;  // 8 lines
  expect_error<InputError>([&] { read(sq + "sphere a 1\n"); },
                           {"s.mgf:9", "unknown entity 'sphere'"});
  expect_error<InputError>([&] { read(sq + "v e =\n p 1 x 0\n"); }, {"s.mgf:10", "'x'"});
  expect_error<InputError>([&] { read(sq + "f a b nosuch\n"); }, {"s.mgf:9", "vertex 'nosuch'"});
  expect_error<InputError>([&] { read(sq + "m nosuch\nf a b c\n"); },
                           {"s.mgf:9", "material 'nosuch'"});
  expect_error<InputError>([&] { read(sq + "c nosuch\n"); }, {"s.mgf:9", "colour 'nosuch'"});
  expect_error<InputError>([&] { read(sq + "f a b c\no\n"); }, {"s.mgf:10", "'o' end"});
  expect_error<InputError>([&] { read(sq + "f a b c\nxf\n"); }, {"s.mgf:10", "'xf' end"});
  expect_error<InputError>([&] { read(sq + "o box\nf a b c\n"); },
                           {"s.mgf:9", "box", "not closed"});
  expect_error<InputError>([&] { read(sq + "xf -t 1 0 0\nf a b c\n"); }, {"s.mgf:9", "not closed"});
  expect_error<InputError>([&] { read(sq + "xf -a 2 -t 1 0 0\nf a b c\n"); },
                           {"s.mgf:9", "no matching"});
  expect_error<InputError>([&] { read(sq + "xf -q 1\nxf\n"); }, {"s.mgf:9", "'-q'"});
  expect_error<InputError>([&] { read(sq + "xf -a 1.5 -t 1 0 0\nxf\n"); }, {"s.mgf:9", "-a"});
  expect_error<InputError>([&] { read(sq + "m x =\n rd 1.5\n"); }, {"s.mgf:10", "'rd'"});
  expect_error<InputError>([&] { read(sq + "m x =\n ed -1\n"); }, {"s.mgf:10", "'ed'"});
  expect_error<InputError>([&] { read(sq + "c x =\n cxy .8 .5\n"); }, {"s.mgf:10", "chromaticity"});
  expect_error<InputError>([&] { read(sq + "f a b\n"); }, {"s.mgf:9", "at least 3"});
  expect_error<InputError>([&] { read(sq + "fh a b c - d\n"); }, {"s.mgf:9", "'fh'"});
  expect_error<InputError>([&] { read(sq + "sides 3\n"); }, {"s.mgf:9", "sides"});
  // A spectrum without positive luminance may be defined (illums.mgf's daylight basis
  // functions) but not used.
  expect_error<InputError>(
      [&] { read(sq + "c s =\n cspec 400 700 -1 -1\nm x =\n c s\n rd .5\nf a b c\n"); },
      {"s.mgf:13", "no positive luminance", "s.mgf:10"});
  expect_error<InputError>([&] { read("# nothing\n"); }, {"s.mgf", "no geometry"});
  expect_error<InputError>([] { read_mgf("/nonexistent/radlab/x.mgf", quiet()); },
                           {"/nonexistent/radlab/x.mgf", "cannot open"});
}

TEST(MgfErrors, IesLuminairesAreIgnoredWithAWarning) {
  MgfStats stats;
  Scene s = read(std::string(kSquare) + "f a b c d\nies lamp.ies -t 0 0 1\n", &stats);
  EXPECT_EQ(s.polygons.size(), 1u);
  EXPECT_EQ(stats.ignored_lines, 1);
  ASSERT_EQ(stats.warnings.size(), 1u);
  EXPECT_NE(stats.warnings[0].find("ies"), std::string::npos);
}

TEST(MgfLoader, DispatchesOnTheExtension) {
  TempDir dir;
  const std::string path =
      dir.write("room.MGF", std::string(kSquare) + "m l =\n ed 1\nf a b c d\n");
  LoadedScene loaded = load_scene(path, false);
  EXPECT_EQ(loaded.scene.polygons.size(), 1u);
  EXPECT_EQ(loaded.scene.emitter_count(), 1);
  EXPECT_EQ(loaded.scene.name, path);
}

// ---- the shared RenderPark scenes -----------------------------------------------------------

struct SharedScene {
  const char* file;
  size_t read;      // polygons made by the reader (faces + tessellated primitives)
  size_t polygons;  // after validation
  int dropped;
  int split;
  int emitters;  // emitting polygons after validation
  size_t materials;
};

void PrintTo(const SharedScene& scene, std::ostream* out) {
  *out << scene.file;
}

// The counts docs/scenes.md states (deterministic: default tessellation, 16 segments around).
// Polygons and emitters are after validation, which also removes coincident same-facing
// overlaps (scene/overlap.h): hosp.mgf's second copy of the furniture goes, graz.mgf
// gains the pieces of polygons cut around an overlap.
const SharedScene kShared[] = {
    {"cube.mgf", 66, 66, 0, 0, 2, 9},
    {"office2/office2.mgf", 422, 430, 0, 8, 1, 50},
    {"corridor.mgf", 483, 489, 0, 2, 57, 9},
    {"salon/classroom.mgf", 5250, 5826, 0, 576, 24, 631},
    {"office3/office.mgf", 12463, 12592, 0, 7, 130, 35},
    {"office1/graz.mgf", 13796, 14064, 0, 142, 8, 66},
    // 12,259: 12,235 until geometry::area summed edge vectors instead of Newell's products of
    // corners (the loader's area thresholds then saw the true areas of some tiny pieces: 12,219),
    // then face-to-face contacts (window frames on their sills) removed from both sides, which
    // cuts the sills and walls into more pieces. graz.mgf and soda.mgf gain pieces the same way.
    // 12,530 since non-convex faces are split by a constrained Delaunay triangulation (issue
    // 36.1): the ear clipper had kept nothing or part of 43 faces (counter.mgf:230, 0.88 of its
    // 2.13 m^2), and other triangles cut differently around overlaps. office3 (its wall with a
    // window, office.mgf:41), soda (soda.mgf:983) and graz (other triangles) moved the same way.
    {"hospital/hosp.mgf", 22271, 12530, 0, 312, 44, 164},
    {"soda.mgf", 53099, 53216, 0, 10, 640, 81},
    // The hospital with each piece of furniture once (hosp.mgf includes them twice; the loader
    // now removes the second copy, so both load as about the same 12,2xx polygons).
    {"hospital/structure.mgf", 11230, 12526, 0, 167, 44, 85},
    {"examp1.mgf", 198, 198, 0, 0, 32, 4},
    {"floor_gloss.mgf", 136, 136, 0, 0, 1, 4},
};

class SharedMgfScene : public ::testing::TestWithParam<SharedScene> {};

TEST_P(SharedMgfScene, LoadsWithTheDocumentedCounts) {
  const char* root = std::getenv("RADLAB_SHARED_SCENES");
  if (!root || !*root) {
    RADLAB_SHARED_MISSING("RADLAB_SHARED_SCENES is not set");
  }
  const std::filesystem::path path = std::filesystem::path(root) / "renderpark" / GetParam().file;
  if (!std::filesystem::exists(path)) {
    RADLAB_SHARED_MISSING(path << " is missing");
  }
  MgfStats stats;
  // The hospital includes ../Materials: includes outside the scene's folder need the opt-in.
  const std::string include_root = (std::filesystem::path(root) / "renderpark").string();
  MgfOptions options = quiet();
  options.include_root = include_root;
  Scene raw = read_mgf(path.string(), options, &stats);
  EXPECT_EQ(raw.polygons.size(), GetParam().read);
  set_mgf_include_root(include_root);
  LoadedScene loaded = load_scene(path.string(), false);
  set_mgf_include_root("");
  EXPECT_EQ(loaded.scene.polygons.size(), GetParam().polygons);
  EXPECT_EQ(loaded.report.dropped, GetParam().dropped);
  EXPECT_EQ(loaded.report.triangulated, GetParam().split);
  EXPECT_EQ(loaded.scene.emitter_count(), GetParam().emitters);
  EXPECT_EQ(loaded.scene.materials.size(), GetParam().materials);
  // The loader's area account (issue 36.1): every square metre read is kept or named by a
  // warning. Splits lose nothing (office3/office.mgf:41, a wall with a window joined by a seam,
  // lost 7.73 m^2 to the ear clipper while the counts said 0 dropped); what the overlap repair
  // removes is the sum of what its warnings name. kAreaTolerance is rounding (1e-9 relative).
  const AreaAccount& area = loaded.report.area;
  EXPECT_EQ(area.split_lost, 0.0);
  EXPECT_NEAR(area.unaccounted(), 0.0, kAreaTolerance * area.read);
  double kept = 0.0;
  for (const Polygon& p : loaded.scene.polygons) kept += geometry::area(p.vertices);
  EXPECT_NEAR(area.kept, kept, kAreaTolerance * area.read);
  // The reader's polygons' area, summed independently of the loader.
  double read = 0.0;
  for (const Polygon& p : raw.polygons) read += geometry::area(p.vertices);
  EXPECT_NEAR(area.read, read, kAreaTolerance * read);
  for (const Material& m : loaded.scene.materials)
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(m.reflectance[k], 0.0) << m.name;
      EXPECT_LE(m.reflectance[k], 1.0) << m.name;
    }
}

INSTANTIATE_TEST_SUITE_P(RenderPark, SharedMgfScene, ::testing::ValuesIn(kShared),
                         [](const ::testing::TestParamInfo<SharedScene>& param) {
                           std::string name = param.param.file;
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

}  // namespace
}  // namespace radlab
