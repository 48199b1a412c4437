// Images: EXR round trip, PNG structure, and renderer properties that theory fixes — a camera
// inside a closed box sees a constant field exactly, interpolation reproduces vertex values and
// affine fields, a camera looking at nothing renders black.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "formfactor/embree_scene.h"
#include "render/exr_io.h"
#include "render/false_colour.h"
#include "render/png_io.h"
#include "render/renderer.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

Mesh mesh_of(const std::string& spec, int subdiv, Scene* out = nullptr) {
  Scene scene = make_builtin_scene(spec);
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {subdiv, 0.0});
  if (out) *out = scene;
  return mesh;
}

TEST(Exr, RoundTripIsExact) {
  TempDir dir;
  Image image(7, 5);
  for (size_t k = 0; k < image.rgb.size(); ++k)
    image.rgb[k] = float(std::pow(1.7, double(k % 41) - 20.0)) * (k % 3 == 0 ? 1.0f : 0.5f);
  image.rgb[4] = 0.0f;
  write_exr(dir.file("a.exr"), image);
  Image back = read_exr(dir.file("a.exr"));
  ASSERT_EQ(back.width, 7);
  ASSERT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, image.rgb);
}

TEST(Exr, UnwritableAndUnreadablePathsNameTheFile) {
  TempDir dir;
  EXPECT_THROW(write_exr("/nonexistent/radlab/x.exr", Image(2, 2)), InputError);
  std::ofstream(dir.file("junk.exr")) << "not an exr";
  try {
    read_exr(dir.file("junk.exr"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("junk.exr"), std::string::npos);
  }
}

TEST(Png, HasSignatureAndHeaderSize) {
  TempDir dir;
  Image image(13, 9);
  for (float& v : image.rgb) v = 0.3f;
  write_png(dir.file("a.png"), image, 2.0);
  std::ifstream in(dir.file("a.png"), std::ios::binary);
  unsigned char bytes[24];
  in.read(reinterpret_cast<char*>(bytes), 24);
  const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(std::equal(signature, signature + 8, bytes));
  EXPECT_EQ(std::string(reinterpret_cast<char*>(bytes) + 12, 4), "IHDR");
  auto be32 = [&](int at) {
    return (uint32_t(bytes[at]) << 24) | (uint32_t(bytes[at + 1]) << 16) |
           (uint32_t(bytes[at + 2]) << 8) | uint32_t(bytes[at + 3]);
  };
  EXPECT_EQ(be32(16), 13u);
  EXPECT_EQ(be32(20), 9u);
}

TEST(Renderer, ConstantFieldInsideAClosedBoxIsExact) {
  Scene scene;
  Mesh mesh = mesh_of("furnace", 3, &scene);
  EmbreeScene embree(mesh);
  Radiosity field(1, mesh.size(), 2.0);
  Image image = render_radiosity(mesh, embree, field, *scene.camera, 48, 32);
  // Every ray from inside hits a front face; interpolation weights sum to 1.
  for (float v : image.rgb) EXPECT_NEAR(v, 2.0f, 1e-5f);
}

TEST(Renderer, InterpolationReproducesVerticesAndAffineFields) {
  const std::vector<Vec3> quad = {{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {0, 1.5, 0}};
  const std::vector<Vec3> tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Vec3> pentagon = {{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {1, 2, 0}, {-0.5, 1, 0}};
  const Vec3 n(0, 0, 1);
  for (const auto* poly : {&quad, &tri, &pentagon}) {
    std::vector<double> w(poly->size());
    for (size_t k = 0; k < poly->size(); ++k) {  // at a vertex: that vertex's value
      interpolation_weights(*poly, n, (*poly)[k], w);
      for (size_t m = 0; m < w.size(); ++m) EXPECT_NEAR(w[m], m == k ? 1.0 : 0.0, 1e-9);
    }
    // Inside: weights sum to 1 and reproduce an affine function (linear precision holds for
    // barycentric and mean-value coordinates, and for bilinear maps of affine functions).
    const Vec3 p(0.9, 0.6, 0.0);
    interpolation_weights(*poly, n, p, w);
    double sum = 0.0, f = 0.0;
    for (size_t m = 0; m < w.size(); ++m) {
      sum += w[m];
      f += w[m] * (3.0 * (*poly)[m].x - 2.0 * (*poly)[m].y + 1.0);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    if (poly != &quad) {
      EXPECT_NEAR(f, 3.0 * p.x - 2.0 * p.y + 1.0, 1e-9);
    }
  }
  // The bilinear map reproduces functions bilinear in its own parameters: check its inverse.
  std::vector<double> w(4);
  const double s = 0.3, t = 0.7;
  const Vec3 p = (1 - s) * (1 - t) * quad[0] + s * (1 - t) * quad[1] + s * t * quad[2] +
                 (1 - s) * t * quad[3];
  interpolation_weights(quad, n, p, w);
  EXPECT_NEAR(w[0], (1 - s) * (1 - t), 1e-9);
  EXPECT_NEAR(w[2], s * t, 1e-9);
}

TEST(Renderer, SmoothShadingIsContinuousAcrossElements) {
  // A field linear in the centroid's x on a finely meshed furnace: neighbouring pixels never
  // differ by more than the field changes over a pixel's footprint plus one element's step.
  Scene scene;
  Mesh mesh = mesh_of("furnace", 8, &scene);
  EmbreeScene embree(mesh);
  Radiosity field(1, mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) field.at(0, e) = 1.0 + mesh.centroid[e].x;
  Image smooth = render_radiosity(mesh, embree, field, *scene.camera, 64, 64);
  std::vector<glm::dvec3> flat_values(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) flat_values[e] = glm::dvec3(field.at(0, e));
  Image flat = render_field(mesh, embree, flat_values, *scene.camera, 64, 64, false);
  auto largest_jump = [](const Image& im) {
    double worst = 0.0;
    for (int y = 0; y < im.height; ++y)
      for (int x = 1; x < im.width; ++x)
        worst = std::max(worst, double(std::abs(im.pixel(x, y)[0] - im.pixel(x - 1, y)[0])));
    return worst;
  };
  // Flat shading jumps by a whole element step (1/8 in x); smooth shading stays well below it.
  EXPECT_GT(largest_jump(flat), 0.1);
  EXPECT_LT(largest_jump(smooth), 0.5 * largest_jump(flat));
}

TEST(Renderer, LookingAtNothingIsBlack) {
  Scene scene;
  Mesh mesh = mesh_of("cube", 2, &scene);
  EmbreeScene embree(mesh);
  Camera away;
  away.eye = Vec3(0.5, 0.5, -5.0);
  away.look_at = Vec3(0.5, 0.5, -10.0);  // looking away from the cube
  Image image = render_radiosity(mesh, embree, Radiosity(1, mesh.size(), 1.0), away, 16, 16);
  for (float v : image.rgb) EXPECT_EQ(v, 0.0f);
}

TEST(Renderer, CornellBoxFillsItsCamera) {
  Scene scene;
  Mesh mesh = mesh_of("cornell", 2, &scene);
  EmbreeScene embree(mesh);
  Image image = render_radiosity(mesh, embree, Radiosity(3, mesh.size(), 1.0), *scene.camera, 64, 64);
  size_t lit = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) lit += image.pixel(x, y)[1] > 0.99f ? 1 : 0;
  // The published camera frames the open front: the box fills nearly all of the view.
  EXPECT_GT(double(lit) / (64.0 * 64.0), 0.8);
}

TEST(FalseColour, CohenSchemeAndPError) {
  EXPECT_EQ(cohen_error_colour(0.0), glm::dvec3(0.5));
  EXPECT_GT(cohen_error_colour(-1.0).z, 0.9);  // under-estimate: blue
  EXPECT_GT(cohen_error_colour(+1.0).x, 0.9);  // over-estimate: red
  EXPECT_EQ(cohen_error_colour(5.0), cohen_error_colour(1.0));  // saturates
  EXPECT_GT(p_error_colour(-0.5).y, p_error_colour(-0.5).x);     // under-lit: green
}

}  // namespace
}  // namespace radlab
