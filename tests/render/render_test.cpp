// Images: EXR round trip, PNG structure and errors, exposure, and renderer properties that theory
// fixes — a camera inside a closed box sees a constant field exactly, interpolation is exact at
// vertices, reproduces affine fields and is continuous across shared edges, back faces are culled,
// a camera looking at nothing renders black, the default camera frames the whole scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <tuple>

#include "core/error.h"
#include "formfactor/visibility/embree_scene.h"
#include "render/exr_io.h"
#include "render/false_colour.h"
#include "render/interpolation.h"
#include "render/png_io.h"
#include "render/renderer.h"
#include "scene/builtin/builtin_scenes.h"
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

std::vector<glm::dvec3> constant_field(const Mesh& mesh, double value) {
  return std::vector<glm::dvec3>(mesh.size(), glm::dvec3(value));
}

// ---------------------------------------------------------------------------------------- EXR

TEST(Exr, RoundTripIsBitExact) {
  TempDir dir;
  Image image(7, 5);
  for (size_t k = 0; k < image.rgb.size(); ++k)
    image.rgb[k] = float(std::pow(1.7, double(k % 41) - 20.0)) * (k % 3 == 0 ? 1.0f : -0.5f);
  // Values half would change: zero, -0, a subnormal, the largest float, infinity, 1 + 2^-23.
  image.rgb[0] = 0.0f;
  image.rgb[1] = -0.0f;
  image.rgb[2] = std::numeric_limits<float>::denorm_min();
  image.rgb[3] = std::numeric_limits<float>::max();
  image.rgb[4] = std::numeric_limits<float>::infinity();
  image.rgb[5] = 1.0f + std::numeric_limits<float>::epsilon();
  write_exr(dir.file("a.exr"), image);
  const Image back = read_exr(dir.file("a.exr"));
  ASSERT_EQ(back.width, 7);
  ASSERT_EQ(back.height, 5);
  ASSERT_EQ(back.rgb.size(), image.rgb.size());
  EXPECT_EQ(std::memcmp(back.rgb.data(), image.rgb.data(), image.rgb.size() * sizeof(float)), 0);
}

TEST(Exr, KeepsPixelOrderAndChannels) {
  TempDir dir;
  Image image(3, 2);
  image.pixel(2, 0)[0] = 1.0f;  // top-right red
  image.pixel(0, 1)[2] = 2.0f;  // bottom-left blue
  write_exr(dir.file("b.exr"), image);
  const Image back = read_exr(dir.file("b.exr"));
  EXPECT_EQ(back.pixel(2, 0)[0], 1.0f);
  EXPECT_EQ(back.pixel(0, 1)[2], 2.0f);
  EXPECT_EQ(back.pixel(0, 0)[0], 0.0f);
}

TEST(Exr, ErrorsNameTheFile) {
  TempDir dir;
  auto expect_input_error_naming = [](auto&& call, const std::string& name) {
    try {
      call();
      ADD_FAILURE() << "no InputError for " << name;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expect_input_error_naming([] { write_exr("/nonexistent/radlab/x.exr", Image(2, 2)); }, "x.exr");
  std::ofstream(dir.file("junk.exr")) << "not an exr";
  expect_input_error_naming([&] { read_exr(dir.file("junk.exr")); }, "junk.exr");
  expect_input_error_naming([&] { read_exr(dir.file("missing.exr")); }, "missing.exr");
  expect_input_error_naming([&] { write_exr(dir.file("empty.exr"), Image(0, 4)); }, "empty.exr");
  Image broken(4, 4);
  broken.rgb.pop_back();
  EXPECT_THROW(write_exr(dir.file("broken.exr"), broken), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------- PNG

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

uint32_t big_endian32(const std::vector<unsigned char>& b, size_t at) {
  return (uint32_t(b[at]) << 24) | (uint32_t(b[at + 1]) << 16) | (uint32_t(b[at + 2]) << 8) |
         uint32_t(b[at + 3]);
}

TEST(Png, HasSignatureAndHeader) {
  TempDir dir;
  Image image(13, 9);
  for (float& v : image.rgb) v = 0.3f;
  image.rgb[7] = std::numeric_limits<float>::quiet_NaN();  // must not upset the writer
  image.rgb[8] = std::numeric_limits<float>::infinity();
  write_png(dir.file("a.png"), image, 2.0);
  write_png_ldr(dir.file("b.png"), image);
  for (const char* name : {"a.png", "b.png"}) {
    const std::vector<unsigned char> bytes = read_bytes(dir.file(name));
    ASSERT_GE(bytes.size(), 33u) << name;
    const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    EXPECT_TRUE(std::equal(signature, signature + 8, bytes.begin())) << name;
    EXPECT_EQ(big_endian32(bytes, 8), 13u);  // IHDR data length
    EXPECT_EQ(std::string(bytes.begin() + 12, bytes.begin() + 16), "IHDR");
    EXPECT_EQ(big_endian32(bytes, 16), 13u);  // width
    EXPECT_EQ(big_endian32(bytes, 20), 9u);   // height
    EXPECT_EQ(bytes[24], 8);                  // bit depth
    EXPECT_EQ(bytes[25], 2);                  // colour type: RGB
  }
}

TEST(Png, ErrorsNameTheFileAndLeaveNoFile) {
  TempDir dir;
  Image image(2, 2);
  try {
    write_png("/nonexistent/radlab/y.png", image, 1.0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("y.png"), std::string::npos);
  }
  EXPECT_THROW(write_png(dir.file("c.png"), image, 0.0), InputError);
  EXPECT_THROW(write_png(dir.file("c.png"), image, std::nan("")), InputError);
  EXPECT_THROW(write_png_ldr(dir.file("c.png"), Image(0, 0)), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir.file("c.png")));
}

TEST(Png, AutoExposureMapsThe97thPercentileOfLitPixels) {
  Image image(10, 20);  // 100 black pixels, then grey levels 1..100
  for (int k = 0; k < 100; ++k)
    for (int c = 0; c < 3; ++c) image.pixel(k % 10, 10 + k / 10)[c] = float(k + 1);
  // Lit pixels sorted: 1..100; the 97th percentile (index 0.97 * 99 -> 96) is 97.
  EXPECT_NEAR(auto_exposure(image), 0.85 / 97.0, 1e-12);
  EXPECT_EQ(auto_exposure(Image(4, 4)), 1.0);  // nothing lit
}

// -------------------------------------------------------------------------------- interpolation

const Vec3 kUp(0, 0, 1);

// Convex polygons in z = 0, counter-clockwise seen from +z.
std::vector<std::vector<Vec3>> test_polygons() {
  return {
      {{0, 0, 0}, {1, 0, 0}, {0.2, 1, 0}},                           // triangle
      {{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {0, 1.5, 0}},              // general quad
      {{0, 0, 0}, {1, 0, 0}, {1.01, 0.01, 0}, {0, 3, 0}},            // quad, almost a triangle
      {{0, 0, 0}, {10, 0, 0}, {10, 0.1, 0}, {0, 0.1, 0}},            // thin rectangle
      {{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {1, 2, 0}, {-0.5, 1, 0}},  // pentagon
      {{1, 0, 0}, {2, 0.5, 0}, {2, 1.5, 0}, {1, 2, 0}, {0, 1.5, 0}, {0, 0.5, 0}},  // hexagon
  };
}

// A random point inside a convex polygon: a random convex combination of its corners.
Vec3 random_inside(const std::vector<Vec3>& poly, std::mt19937& rng) {
  std::exponential_distribution<double> weight(1.0);
  Vec3 p(0.0);
  double total = 0.0;
  for (const Vec3& c : poly) {
    const double w = weight(rng);
    p += w * c;
    total += w;
  }
  return p / total;
}

double affine(const Vec3& p) {
  return 3.0 * p.x - 2.0 * p.y + 1.0;
}

TEST(Interpolation, WeightsAreExactAtCorners) {
  for (const auto& poly : test_polygons()) {
    std::vector<double> w(poly.size());
    for (size_t k = 0; k < poly.size(); ++k) {
      interpolation_weights(poly, kUp, poly[k], w);
      for (size_t m = 0; m < w.size(); ++m)
        EXPECT_NEAR(w[m], m == k ? 1.0 : 0.0, 1e-12) << poly.size() << " corners, at " << k;
    }
  }
}

TEST(Interpolation, WeightsReproduceAffineFieldsInside) {
  std::mt19937 rng(7);
  for (const auto& poly : test_polygons()) {
    std::vector<double> w(poly.size());
    for (int trial = 0; trial < 200; ++trial) {
      const Vec3 p = random_inside(poly, rng);
      interpolation_weights(poly, kUp, p, w);
      double sum = 0.0, f = 0.0;
      for (size_t m = 0; m < w.size(); ++m) {
        sum += w[m];
        f += w[m] * affine(poly[m]);
        EXPECT_GE(w[m], -1e-12);  // inside a convex polygon all three kinds are non-negative
      }
      EXPECT_NEAR(sum, 1.0, 1e-12);
      EXPECT_NEAR(f, affine(p), 1e-9) << poly.size() << " corners";
    }
  }
}

TEST(Interpolation, WeightsDoNotDependOnTheNormalsOrientation) {
  for (const auto& poly : test_polygons()) {
    std::vector<double> up(poly.size()), down(poly.size());
    const Vec3 p = 0.3 * poly[0] + 0.3 * poly[1] + 0.4 * poly[2];
    interpolation_weights(poly, kUp, p, up);
    interpolation_weights(poly, -kUp, p, down);
    for (size_t m = 0; m < poly.size(); ++m) EXPECT_NEAR(up[m], down[m], 1e-12);
  }
}

TEST(Interpolation, WeightsAreLinearAlongEdges) {
  // On an edge only its two corners count, in proportion: what makes neighbours agree.
  for (const auto& poly : test_polygons()) {
    std::vector<double> w(poly.size());
    for (size_t k = 0; k < poly.size(); ++k) {
      const size_t j = (k + 1) % poly.size();
      const Vec3 p = 0.7 * poly[k] + 0.3 * poly[j];
      interpolation_weights(poly, kUp, p, w);
      for (size_t m = 0; m < w.size(); ++m)
        EXPECT_NEAR(w[m],
                    m == k   ? 0.7
                    : m == j ? 0.3
                             : 0.0,
                    1e-9)
            << poly.size() << " corners, edge " << k;
    }
  }
}

// A scene of one quad (not a parallelogram), one triangle and one pentagon, all in z = 0 but far
// apart, plus an unsplit hexagon when subdiv = 1.
Mesh flat_mesh(int subdiv) {
  std::vector<std::vector<Vec3>> polygons = test_polygons();
  polygons.erase(polygons.begin() + 2, polygons.begin() + 4);  // keep the better-shaped quad
  for (size_t p = 0; p < polygons.size(); ++p)
    for (Vec3& v : polygons[p]) v += Vec3(10.0 * double(p), 0.0, 0.0);
  Scene scene = testing::scene_of(polygons);
  validate_scene(scene);
  return build_mesh(scene, {subdiv, 0.0});
}

TEST(Interpolation, VertexValuesOfALinearFieldAreExactAtInteriorVertices) {
  // On a uniform parallelogram grid the elements around an interior vertex are point-symmetric
  // about it with equal areas, so the area-weighted mean of a linear field is its vertex value.
  Scene scene = testing::scene_of({{{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {0.5, 1, 0}}});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {6, 0.0});
  std::vector<glm::dvec3> field(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) field[e] = glm::dvec3(affine(mesh.centroid[e]));
  const std::vector<glm::dvec3> vertex = smooth_vertex_values(mesh, field);
  std::vector<int> uses(mesh.vertices.size(), 0);
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) ++uses[v];
  int interior = 0;
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (uses[v] != 4) continue;
    ++interior;
    EXPECT_NEAR(vertex[v].x, affine(mesh.vertices[v]), 1e-12);
  }
  EXPECT_EQ(interior, 25);
}

TEST(Interpolation, SmoothFieldIsContinuousAcrossSharedEdges) {
  // Random element values; at points on every edge two elements of one polygon share (matched by
  // position, so the seams between the mesher's fan triangles of the pentagon count too), both
  // elements must interpolate the same value.
  for (int subdiv : {1, 3}) {
    const Mesh mesh = flat_mesh(subdiv);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> uniform(0.0, 10.0);
    std::vector<glm::dvec3> field(mesh.size());
    for (auto& f : field) f = glm::dvec3(uniform(rng), uniform(rng), uniform(rng));
    const std::vector<glm::dvec3> vertex = smooth_vertex_values(mesh, field);

    using Point = std::tuple<double, double, double>;
    auto point = [](const Vec3& v) { return Point(v.x, v.y, v.z); };
    std::map<std::pair<Point, Point>, std::vector<size_t>> elements_of_edge;
    for (size_t e = 0; e < mesh.size(); ++e) {
      const auto ids = mesh.element_vertices(e);
      for (size_t k = 0; k < ids.size(); ++k) {
        Point a = point(mesh.vertices[ids[k]]), b = point(mesh.vertices[ids[(k + 1) % ids.size()]]);
        if (b < a) std::swap(a, b);
        elements_of_edge[{a, b}].push_back(e);
      }
    }
    int shared = 0;
    for (const auto& [edge, elements] : elements_of_edge) {
      if (elements.size() < 2) continue;
      ASSERT_EQ(elements.size(), 2u);
      ASSERT_EQ(mesh.polygon[elements[0]], mesh.polygon[elements[1]]);
      ++shared;
      const Vec3 a(std::get<0>(edge.first), std::get<1>(edge.first), std::get<2>(edge.first));
      const Vec3 b(std::get<0>(edge.second), std::get<1>(edge.second), std::get<2>(edge.second));
      for (double s : {0.0, 0.37, 1.0}) {
        const Vec3 p = (1 - s) * a + s * b;
        const glm::dvec3 left = interpolate_on_element(mesh, vertex, elements[0], p);
        const glm::dvec3 right = interpolate_on_element(mesh, vertex, elements[1], p);
        EXPECT_NEAR(glm::length(left - right), 0.0, 1e-9) << "subdiv " << subdiv;
      }
    }
    // Interior edges at subdiv 3: quad grid 2 * 3 * 2; triangle grid 9; a fan of f triangles has
    // 9 per triangle plus 3 on each of its f - 1 seams (pentagon f = 3, hexagon f = 4).
    EXPECT_EQ(shared, subdiv == 1 ? 0 : 12 + 9 + (27 + 6) + (36 + 9));
  }
}

TEST(Interpolation, VertexValuesInterpolateBackAtVertices) {
  const Mesh mesh = flat_mesh(2);
  std::vector<glm::dvec3> field(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) field[e] = glm::dvec3(double(e), 1.0, -double(e));
  const std::vector<glm::dvec3> vertex = smooth_vertex_values(mesh, field);
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) {
      const glm::dvec3 at = interpolate_on_element(mesh, vertex, e, mesh.vertices[v]);
      EXPECT_NEAR(glm::length(at - vertex[v]), 0.0, 1e-9);
    }
}

// ------------------------------------------------------------------------------------ renderer

TEST(Renderer, ConstantFieldInsideAClosedBoxIsExact) {
  Scene scene;
  const Mesh mesh = mesh_of("furnace", 3, &scene);
  const EmbreeScene embree(mesh);
  const Radiosity field(1, mesh.size(), 2.0);
  const Image image = render_radiosity(mesh, embree, field, *scene.camera, 48, 32);
  ASSERT_EQ(image.width, 48);
  ASSERT_EQ(image.height, 32);
  // Every ray from inside hits a front face; interpolation weights sum to 1.
  for (float v : image.rgb) ASSERT_NEAR(v, 2.0f, 1e-6f);
}

TEST(Renderer, ColourChannelsStaySeparate) {
  Scene scene;
  const Mesh mesh = mesh_of("furnace", 2, &scene);
  const EmbreeScene embree(mesh);
  Radiosity field(3, mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    field.at(0, e) = 1.0;
    field.at(1, e) = 2.0;
    field.at(2, e) = 3.0;
  }
  const Image image = render_radiosity(mesh, embree, field, *scene.camera, 8, 8);
  for (size_t k = 0; k < image.rgb.size(); ++k) ASSERT_NEAR(image.rgb[k], float(k % 3 + 1), 1e-6f);
}

double largest_horizontal_jump(const Image& image) {
  double worst = 0.0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 1; x < image.width; ++x)
      worst = std::max(worst, double(std::abs(image.pixel(x, y)[0] - image.pixel(x - 1, y)[0])));
  return worst;
}

TEST(Renderer, SmoothShadingIsContinuousFlatShadingIsNot) {
  // A field linear in the centroid's x on a finely meshed furnace. Flat shading jumps by a whole
  // element step (1/8) at element edges; smooth shading changes by at most the field's change
  // over a pixel's footprint.
  Scene scene;
  const Mesh mesh = mesh_of("furnace", 8, &scene);
  const EmbreeScene embree(mesh);
  std::vector<glm::dvec3> field(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) field[e] = glm::dvec3(1.0 + mesh.centroid[e].x);
  const Image smooth = render_field(mesh, embree, field, *scene.camera, 64, 64, true);
  const Image flat = render_field(mesh, embree, field, *scene.camera, 64, 64, false);
  EXPECT_GT(largest_horizontal_jump(flat), 0.1);
  EXPECT_LT(largest_horizontal_jump(smooth), 0.5 * largest_horizontal_jump(flat));
}

TEST(Renderer, FlatShadingShowsEachElementsOwnValue) {
  Scene scene;
  const Mesh mesh = mesh_of("furnace", 4, &scene);
  const EmbreeScene embree(mesh);
  std::vector<glm::dvec3> field(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) field[e] = glm::dvec3(double(e % 7));
  const Image image = render_field(mesh, embree, field, *scene.camera, 32, 32, false);
  // Pixels inside one element show an integer 0..6; only pixels on an edge average two.
  int integral = 0;
  for (size_t k = 0; k < image.rgb.size(); k += 3)
    integral += image.rgb[k] == std::round(image.rgb[k]) ? 1 : 0;
  EXPECT_GT(integral, int(image.pixel_count() / 2));
}

TEST(Renderer, LookingAtNothingIsBlack) {
  Scene scene;
  const Mesh mesh = mesh_of("cube", 2, &scene);
  const EmbreeScene embree(mesh);
  Camera away;
  away.eye = Vec3(0.5, 0.5, -5.0);
  away.look_at = Vec3(0.5, 0.5, -10.0);  // looking away from the cube
  const Image image = render_field(mesh, embree, constant_field(mesh, 1.0), away, 16, 16, true);
  for (float v : image.rgb) ASSERT_EQ(v, 0.0f);
}

TEST(Renderer, BackFacesAreCulled) {
  // One square facing +z: seen from above it shows, from below it is culled (black).
  Scene scene = testing::scene_of({testing::square_z(0.0, true)});
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {2, 0.0});
  const EmbreeScene embree(mesh);
  Camera camera;
  camera.look_at = Vec3(0.5, 0.5, 0.0);
  camera.eye = Vec3(0.5, 0.5, 1.0);
  camera.vertical_fov_degrees = 20.0;  // the square fills the view
  const Image front = render_field(mesh, embree, constant_field(mesh, 1.0), camera, 8, 8, true);
  for (float v : front.rgb) ASSERT_NEAR(v, 1.0f, 1e-6f);
  camera.eye = Vec3(0.5, 0.5, -1.0);
  const Image back = render_field(mesh, embree, constant_field(mesh, 1.0), camera, 8, 8, true);
  for (float v : back.rgb) ASSERT_EQ(v, 0.0f);
}

TEST(Renderer, CornellBoxFillsItsCamera) {
  Scene scene;
  const Mesh mesh = mesh_of("cornell", 2, &scene);
  const EmbreeScene embree(mesh);
  const Image image =
      render_radiosity(mesh, embree, Radiosity(3, mesh.size(), 1.0), *scene.camera, 64, 64);
  size_t hit = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) hit += image.pixel(x, y)[1] > 0.99f ? 1 : 0;
  // The published camera frames the open front: the box fills nearly all of the view.
  EXPECT_GT(double(hit) / (64.0 * 64.0), 0.8);
}

// True if every pixel on the image's border is black and some pixel is not.
bool framed(const Image& image) {
  bool any = false;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const bool lit = image.pixel(x, y)[0] > 0.0f;
      const bool border = x == 0 || y == 0 || x == image.width - 1 || y == image.height - 1;
      if (lit && border) return false;
      any = any || lit;
    }
  return any;
}

// The largest |coordinate| of any mesh vertex on the image plane, in units of the frame's half
// width or half height (1 = on the frame), for an image of the given aspect; infinity if a vertex
// is not in front of the camera.
double frame_extent(const Mesh& mesh, const Camera& camera, double aspect) {
  const Vec3 forward = glm::normalize(camera.look_at - camera.eye);
  const Vec3 right = glm::normalize(glm::cross(forward, camera.up));
  const Vec3 up = glm::cross(right, forward);
  const double tan_half = std::tan(0.5 * camera.vertical_fov_degrees * std::numbers::pi / 180.0);
  double extent = 0.0;
  for (const Vec3& v : mesh.vertices) {
    const Vec3 d = v - camera.eye;
    const double depth = glm::dot(d, forward);
    if (depth <= 0.0) return std::numeric_limits<double>::infinity();
    extent = std::max({extent, std::abs(glm::dot(d, right) / depth) / (aspect * tan_half),
                       std::abs(glm::dot(d, up) / depth) / tan_half});
  }
  return extent;
}

TEST(Renderer, DefaultCameraFramesTheWholeScene) {
  for (const char* spec : {"furnace", "furnace:lx=3,ly=0.5,lz=1", "cornell"}) {
    const Mesh mesh = mesh_of(spec, 2);
    const EmbreeScene embree(mesh);
    for (double aspect : {1.0, 0.5, 2.0}) {
      const Camera camera = default_camera(mesh, aspect);
      EXPECT_EQ(camera.vertical_fov_degrees, 45.0);
      // Every vertex inside the frame, none outside the bounding box's sphere fit.
      EXPECT_LT(frame_extent(mesh, camera, aspect), 0.96) << spec << " aspect " << aspect;
      // The render agrees: something shows (the furnace's faces point inwards: from outside the
      // near walls are culled and the inside of the far walls shows) and the border is black.
      const int height = 64, width = int(aspect * height);
      EXPECT_TRUE(framed(
          render_field(mesh, embree, constant_field(mesh, 1.0), camera, width, height, false)))
          << spec << " aspect " << aspect;
    }
  }
  EXPECT_THROW(default_camera(Mesh{}), InputError);
}

TEST(Renderer, RejectsBadCamerasAndSizes) {
  const Mesh mesh = mesh_of("furnace", 1);
  const EmbreeScene embree(mesh);
  const auto field = constant_field(mesh, 1.0);
  Camera camera;
  EXPECT_NO_THROW(render_field(mesh, embree, field, camera, 4, 4, true));
  EXPECT_THROW(render_field(mesh, embree, field, camera, 0, 4, true), UsageError);
  EXPECT_THROW(render_field(mesh, embree, field, camera, 4, -1, true), UsageError);
  EXPECT_THROW(render_field(mesh, embree, std::vector<glm::dvec3>(3), camera, 4, 4, true),
               std::invalid_argument);
  Camera same = camera;
  same.look_at = same.eye;
  EXPECT_THROW(check_camera(same), InputError);
  Camera parallel = camera;
  parallel.up = parallel.look_at - parallel.eye;
  EXPECT_THROW(check_camera(parallel), InputError);
  for (double fov : {0.0, 180.0, -5.0, std::nan("")}) {
    Camera bad = camera;
    bad.vertical_fov_degrees = fov;
    EXPECT_THROW(render_field(mesh, embree, field, bad, 4, 4, true), InputError) << fov;
  }
}

// -------------------------------------------------------------------------------- false colour

TEST(FalseColour, CohenGreyBlueRed) {
  EXPECT_EQ(cohen_error_colour(0.0), glm::dvec3(0.5));
  const glm::dvec3 under = cohen_error_colour(-1.0), over = cohen_error_colour(1.0);
  EXPECT_GT(under.z, 0.9);
  EXPECT_LT(under.x, 0.2);
  EXPECT_GT(over.x, 0.9);
  EXPECT_LT(over.z, 0.2);
  EXPECT_EQ(cohen_error_colour(5.0), over);  // saturates
  EXPECT_EQ(cohen_error_colour(-5.0), under);
  EXPECT_EQ(cohen_error_colour(0.5, 0.5), over);  // configurable saturation
  // Half way: half way between grey and the full colour.
  EXPECT_NEAR(glm::length(cohen_error_colour(-0.5) - 0.5 * (glm::dvec3(0.5) + under)), 0.0, 1e-15);
  EXPECT_THROW(cohen_error_colour(0.1, 0.0), std::invalid_argument);
}

TEST(FalseColour, PErrorGreenWhiteYellow) {
  EXPECT_EQ(p_error_colour(0.0), glm::dvec3(0.95));
  const glm::dvec3 under = p_error_colour(-0.5), over = p_error_colour(0.5);
  EXPECT_GT(under.y, under.x);  // green
  EXPECT_GT(under.y, under.z);
  EXPECT_GT(over.x, over.z);  // yellow
  EXPECT_GT(over.y, over.z);
  EXPECT_EQ(p_error_colour(3.0), over);
}

TEST(FalseColour, ColoursAreDisplayValuesAndMarkMissingValues) {
  for (double e = -3.0; e <= 3.0; e += 0.01)
    for (const glm::dvec3& c : {cohen_error_colour(e), p_error_colour(e)})
      for (int k = 0; k < 3; ++k) {
        EXPECT_GE(c[k], 0.0);
        EXPECT_LE(c[k], 1.0);
      }
  EXPECT_EQ(cohen_error_colour(std::nan("")), glm::dvec3(1.0, 0.0, 1.0));
  EXPECT_EQ(p_error_colour(std::numeric_limits<double>::infinity()), glm::dvec3(1.0, 0.0, 1.0));
}

}  // namespace
}  // namespace radlab
