#include "scene/builtin/builtin_scenes.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "core/error.h"
#include "core/text.h"
#include "scene/builtin/building_scenes.h"
#include "scene/builtin/paper_scenes.h"
#include "scene/builtin/stability_scenes.h"
#include "scene/geometry.h"

namespace radlab {
namespace {

// Reverses the winding if needed so the front side faces `point` (or faces away from it).
void orient(Polygon& polygon, const Vec3& point, bool towards) {
  Vec3 n = geometry::unit_normal(polygon.vertices);
  bool faces = glm::dot(point - geometry::centroid(polygon.vertices), n) > 0;
  if (faces != towards) std::reverse(polygon.vertices.begin(), polygon.vertices.end());
}

int add_material(Scene& scene, std::string name, Rgb rho, Rgb emission = Rgb(0.0)) {
  scene.materials.push_back(Material{std::move(name), rho, emission});
  return int(scene.materials.size() - 1);
}

void add_polygon(Scene& scene, std::vector<Vec3> v, int material, std::string origin) {
  scene.polygons.push_back(Polygon{std::move(v), material, std::move(origin)});
}

// The six faces of an axis-aligned box, front sides inward: floor, ceiling, back, front, left,
// right (y-min, y-max, z-max, z-min, x-min, x-max).
std::vector<std::vector<Vec3>> box_faces(const Vec3& lo, const Vec3& hi) {
  const Vec3 c = 0.5 * (lo + hi);
  std::vector<std::vector<Vec3>> faces = {
      {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z}},
      {{lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}},
      {{lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}},
      {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}},
      {{lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {lo.x, hi.y, hi.z}, {lo.x, lo.y, hi.z}},
      {{hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}, {hi.x, lo.y, hi.z}},
  };
  for (auto& f : faces) {
    Polygon p{f, 0, ""};
    orient(p, c, true);
    f = p.vertices;
  }
  return faces;
}

double positive(ParamBag& bag, const std::string& key, double fallback) {
  double v = bag.get_double(key, fallback);
  if (!(v > 0)) throw UsageError(bag.context() + ": '" + key + "' must be > 0");
  return v;
}

// The Cornell box as published by the Cornell Program of Computer Graphics
// (graphics.cornell.edu/online/box/data.html), millimetres converted to metres. Reflectances and
// light are the RGB values commonly used (e.g. Bitterli's rendering resources): white
// (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05), green (0.14, 0.45, 0.091), light emission
// (17, 12, 4) with reflectance 0.78.
//
// Honest handling of the data's quirks:
// - the red wall is non-planar by ~0.8 mm: scene validation splits it into two planar triangles
//   (with a warning) rather than pretending it is flat;
// - the light lies in the ceiling plane; the ceiling is modelled as four rectangles around the
//   light's opening so no two polygons overlap;
// - there is no front wall: the scene is open, light escapes through the front, and row sums of
//   F are below 1 (the energy ledger reports the escaped power).
Scene make_cornell(ParamBag& bag) {
  const double light_scale = bag.get_double("light_scale", 1.0);
  if (!(light_scale > 0)) throw UsageError(bag.context() + ": 'light_scale' must be > 0");
  Scene scene;
  const int white = add_material(scene, "white", {0.725, 0.71, 0.68});
  const int red = add_material(scene, "red", {0.63, 0.065, 0.05});
  const int green = add_material(scene, "green", {0.14, 0.45, 0.091});
  const int light = add_material(scene, "light", Rgb(0.78), light_scale * Rgb(17.0, 12.0, 4.0));

  auto mm = [](double x, double y, double z) { return Vec3(x, y, z) / 1000.0; };
  const Vec3 room_centre = mm(278.0, 274.4, 279.6);
  auto wall = [&](std::vector<Vec3> v, int material, const char* name) {
    Polygon p{std::move(v), material, std::string("cornell/") + name};
    orient(p, room_centre, true);
    scene.polygons.push_back(std::move(p));
  };
  wall({mm(552.8, 0, 0), mm(0, 0, 0), mm(0, 0, 559.2), mm(549.6, 0, 559.2)}, white, "floor");
  wall({mm(343.0, 548.8, 227.0), mm(343.0, 548.8, 332.0), mm(213.0, 548.8, 332.0),
        mm(213.0, 548.8, 227.0)},
       light, "light");
  // Ceiling (556.0 x 559.2 at y = 548.8) minus the light's opening x in [213,343], z in [227,332].
  wall({mm(0, 548.8, 0), mm(556.0, 548.8, 0), mm(556.0, 548.8, 227.0), mm(0, 548.8, 227.0)}, white,
       "ceiling-front");
  wall({mm(0, 548.8, 332.0), mm(556.0, 548.8, 332.0), mm(556.0, 548.8, 559.2), mm(0, 548.8, 559.2)},
       white, "ceiling-back");
  wall({mm(0, 548.8, 227.0), mm(213.0, 548.8, 227.0), mm(213.0, 548.8, 332.0), mm(0, 548.8, 332.0)},
       white, "ceiling-right");
  wall({mm(343.0, 548.8, 227.0), mm(556.0, 548.8, 227.0), mm(556.0, 548.8, 332.0),
        mm(343.0, 548.8, 332.0)},
       white, "ceiling-left");
  wall({mm(549.6, 0, 559.2), mm(0, 0, 559.2), mm(0, 548.8, 559.2), mm(556.0, 548.8, 559.2)}, white,
       "back-wall");
  wall({mm(0, 0, 559.2), mm(0, 0, 0), mm(0, 548.8, 0), mm(0, 548.8, 559.2)}, green, "right-wall");
  wall({mm(552.8, 0, 0), mm(549.6, 0, 559.2), mm(556.0, 548.8, 559.2), mm(556.0, 548.8, 0)}, red,
       "left-wall");

  auto block = [&](const std::vector<std::vector<Vec3>>& faces, const Vec3& centre,
                   const char* name) {
    for (size_t f = 0; f < faces.size(); ++f) {
      Polygon p{faces[f], white, std::string("cornell/") + name + "-" + std::to_string(f)};
      orient(p, centre, false);
      scene.polygons.push_back(std::move(p));
    }
  };
  block(
      {{mm(130.0, 165.0, 65.0), mm(82.0, 165.0, 225.0), mm(240.0, 165.0, 272.0),
        mm(290.0, 165.0, 114.0)},
       {mm(290.0, 0.0, 114.0), mm(290.0, 165.0, 114.0), mm(240.0, 165.0, 272.0),
        mm(240.0, 0.0, 272.0)},
       {mm(130.0, 0.0, 65.0), mm(130.0, 165.0, 65.0), mm(290.0, 165.0, 114.0),
        mm(290.0, 0.0, 114.0)},
       {mm(82.0, 0.0, 225.0), mm(82.0, 165.0, 225.0), mm(130.0, 165.0, 65.0), mm(130.0, 0.0, 65.0)},
       {mm(240.0, 0.0, 272.0), mm(240.0, 165.0, 272.0), mm(82.0, 165.0, 225.0),
        mm(82.0, 0.0, 225.0)}},
      mm(186.0, 82.5, 168.5), "short-block");
  block({{mm(423.0, 330.0, 247.0), mm(265.0, 330.0, 296.0), mm(314.0, 330.0, 456.0),
          mm(472.0, 330.0, 406.0)},
         {mm(423.0, 0.0, 247.0), mm(423.0, 330.0, 247.0), mm(472.0, 330.0, 406.0),
          mm(472.0, 0.0, 406.0)},
         {mm(472.0, 0.0, 406.0), mm(472.0, 330.0, 406.0), mm(314.0, 330.0, 456.0),
          mm(314.0, 0.0, 456.0)},
         {mm(314.0, 0.0, 456.0), mm(314.0, 330.0, 456.0), mm(265.0, 330.0, 296.0),
          mm(265.0, 0.0, 296.0)},
         {mm(265.0, 0.0, 296.0), mm(265.0, 330.0, 296.0), mm(423.0, 330.0, 247.0),
          mm(423.0, 0.0, 247.0)}},
        mm(368.5, 165.0, 351.5), "tall-block");

  // The published camera: eye (278, 273, -800) mm looking along +z, 35 mm lens, 25 mm film.
  Camera camera;
  camera.eye = mm(278.0, 273.0, -800.0);
  camera.look_at = mm(278.0, 273.0, 0.0);
  camera.up = Vec3(0.0, 1.0, 0.0);
  camera.vertical_fov_degrees = 2.0 * std::atan(12.5 / 35.0) * 180.0 / std::numbers::pi;
  scene.camera = camera;
  return scene;
}

// Default view into an axis-aligned box [0,size]^3 through its open or transparent front face.
Camera box_camera(const Vec3& lo, const Vec3& hi) {
  Camera camera;
  Vec3 c = 0.5 * (lo + hi);
  // Inside the box, near the front wall, looking at the back wall: every face but the front shows.
  camera.eye = Vec3(c.x, c.y, lo.z + 0.02 * (hi.z - lo.z));
  camera.look_at = Vec3(c.x, c.y, hi.z);
  camera.vertical_fov_degrees = 100.0;
  return camera;
}

// Closed box with one emitting face (the ceiling, y = size) and uniform reflectance: the classic
// validation case (the emitter also reflects).
Scene make_cube(ParamBag& bag) {
  const double rho = bag.get_double("rho", 0.5);
  const double emission = bag.get_double("emission", 1.0);
  const double size = positive(bag, "size", 1.0);
  Scene scene;
  const int wall = add_material(scene, "wall", Rgb(rho));
  const int light = add_material(scene, "light", Rgb(rho), Rgb(emission));
  const char* names[] = {"floor", "ceiling", "back", "front", "left", "right"};
  auto faces = box_faces(Vec3(0.0), Vec3(size));
  for (size_t f = 0; f < faces.size(); ++f)
    add_polygon(scene, faces[f], f == 1 ? light : wall, std::string("cube/") + names[f]);
  scene.camera = box_camera(Vec3(0.0), Vec3(size));
  return scene;
}

// Closed box where every face emits E and reflects rho: the furnace, B = E / (1 - rho) exactly,
// whatever the mesh (the rows of F sum to 1).
Scene make_furnace(ParamBag& bag) {
  const double rho = bag.get_double("rho", 0.5);
  const double emission = bag.get_double("emission", 1.0);
  const Vec3 size(positive(bag, "lx", 1.0), positive(bag, "ly", 1.0), positive(bag, "lz", 1.0));
  Scene scene;
  const int m = add_material(scene, "furnace", Rgb(rho), Rgb(emission));
  const char* names[] = {"floor", "ceiling", "back", "front", "left", "right"};
  auto faces = box_faces(Vec3(0.0), size);
  for (size_t f = 0; f < faces.size(); ++f)
    add_polygon(scene, faces[f], m, std::string("furnace/") + names[f]);
  scene.camera = box_camera(Vec3(0.0), size);
  return scene;
}

}  // namespace

const std::vector<BuiltinScene>& builtin_scenes() {
  static const std::vector<BuiltinScene> table = {
      {"cornell",
       "the Cornell box (published geometry, metres; open front; RGB)",
       {{"light_scale", "1", "multiplies the light's emission (17, 12, 4)"}},
       make_cornell},
      {"cube",
       "closed cube, inward faces, the ceiling emits, uniform reflectance (grey)",
       {{"rho", "0.5", "reflectance of every face, in [0,1]"},
        {"emission", "1", "emission of the ceiling"},
        {"size", "1", "edge length (m)"}},
       make_cube},
      {"furnace",
       "closed box, every face emits and reflects alike: B = E/(1-rho) (grey)",
       {{"rho", "0.5", "reflectance of every face, in [0,1]"},
        {"emission", "1", "emission of every face"},
        {"lx", "1", "size along x (m)"},
        {"ly", "1", "size along y (m)"},
        {"lz", "1", "size along z (m)"}},
       make_furnace},
      {"office",
       "two office cubicles, Cohen et al. 1988 (reconstruction; closed; RGB); --subdiv 4: ~7,000 "
       "elements",
       {{"light_scale", "1", "multiplies the luminaires' emission (12, 11.5, 10)"},
        {"rho_scale", "1", "multiplies every reflectance (must stay <= 1)"},
        {"patch", "0.6", "target patch edge (m); the element target assumes the default"}},
       make_office_scene},
      {"room",
       "a simple room, Wu & Wang 2002 example B (reconstruction; closed; RGB); --subdiv 2: "
       "1,360 elements (the paper's: 1,336)",
       {{"light_scale", "1", "multiplies the luminaire's emission (15, 14, 12)"},
        {"rho_scale", "1", "multiplies every reflectance (must stay <= 1)"},
        {"patch", "0.55", "target patch edge (m); the element target assumes the default"}},
       make_room_scene},
      {"computer-room",
       "a computer room, Wu & Wang 2002 example A (reconstruction; closed; RGB); --subdiv 3: "
       "4,860 elements (the paper's: 4,953)",
       {{"light_scale", "1", "multiplies the luminaires' emission (14, 14, 13)"},
        {"rho_scale", "1", "multiplies every reflectance (must stay <= 1)"},
        {"patch", "0.9", "target patch edge (m); the element target assumes the default"}},
       make_computer_room_scene},
      {"floors",
       "k office storeys stacked around an open atrium (scaling family; closed; RGB): "
       "1,856 k + 96 polygons",
       {{"k", "4", "number of storeys (>= 1)"},
        {"patch", "0.5", "target patch edge (m); the polygon count assumes the default"},
        {"light_scale", "1", "multiplies the luminaires' emission (12, 11.5, 10)"}},
       make_floors_scene},
      // Stiff and extreme cases for the stability table (scene/builtin/stability_scenes.h).
      {"tiny-light",
       "4 x 3 x 5 m closed room lit only by a tiny, very bright square below the ceiling (grey)",
       {{"size", "0.001", "the lamp's edge (m)"},
        {"emission", "1e6", "the lamp's emission"},
        {"rho", "0.5", "reflectance of every surface"},
        {"drop", "0.01", "the lamp's distance below the ceiling (m)"}},
       make_tiny_light_scene},
      {"area-ratio",
       "closed unit cube whose floor has a corner piece 'ratio' times smaller than its neighbour "
       "(grey)",
       {{"ratio", "1e6", "area of the big floor piece over the corner piece's (>= 1)"},
        {"rho", "0.9", "reflectance of every face"},
        {"emission", "1", "emission of the ceiling"}},
       make_area_ratio_scene},
      {"slivers",
       "closed unit cube whose floor is a fan of sliver triangles plus one quadrilateral (grey)",
       {{"aspect", "1e-4", "each sliver's height over its length"},
        {"count", "4", "number of slivers"},
        {"rho", "0.9", "reflectance of every face"},
        {"emission", "1", "emission of the ceiling"}},
       make_slivers_scene},
      {"overlap",
       "closed unit cube with a second polygon (a rug) coplanar with its floor: unphysical "
       "input (grey)",
       {{"rug", "0.5", "the rug's edge (m)"},
        {"lift", "0", "the rug's height above the floor (m); 0: coplanar"},
        {"rho", "0.9", "reflectance of the box"},
        {"rug_rho", "0.5", "reflectance of the rug"},
        {"emission", "1", "emission of the ceiling"}},
       make_overlap_scene},
      {"near-pair",
       "two parallel unit squares 'gap' apart, facing each other, open sides; the lower emits "
       "(grey)",
       {{"gap", "0.001", "distance between the squares (m)"},
        {"rho", "0.9", "reflectance of both"},
        {"emission", "1", "emission of the lower square"}},
       make_near_pair_scene},
  };
  return table;
}

Scene make_builtin_scene(const std::string& name_and_parameters) {
  auto colon = name_and_parameters.find(':');
  std::string name = name_and_parameters.substr(0, colon);
  std::string parameters =
      colon == std::string::npos ? std::string() : name_and_parameters.substr(colon + 1);
  for (const BuiltinScene& builtin : builtin_scenes()) {
    if (builtin.name != name) continue;
    ParamBag bag = ParamBag::from_list(parameters, "scene 'builtin:" + name + "'");
    Scene scene = builtin.make(bag);
    bag.finish();
    scene.name = "builtin:" + name_and_parameters;
    return scene;
  }
  std::vector<std::string> names;
  for (const BuiltinScene& builtin : builtin_scenes()) names.push_back(builtin.name);
  throw UsageError("unknown built-in scene '" + name +
                   "'; built-in scenes: " + text::join(names, ", "));
}

}  // namespace radlab
