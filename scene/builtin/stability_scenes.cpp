#include "scene/builtin/stability_scenes.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "scene/geometry.h"

namespace radlab {
namespace {

// Reverses the winding if needed so the front side faces along `normal`.
std::vector<Vec3> facing(std::vector<Vec3> v, const Vec3& normal) {
  if (glm::dot(geometry::unit_normal(v), normal) < 0) std::reverse(v.begin(), v.end());
  return v;
}

// The rectangle [x0,x1] x [z0,z1] at height y, front side along +y (up) or -y (down).
std::vector<Vec3> rect_y(double x0, double x1, double z0, double z1, double y, bool up) {
  return facing({{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}}, Vec3(0, up ? 1 : -1, 0));
}

class Builder {
 public:
  explicit Builder(ParamBag& bag) : bag_(bag) {}

  double number(const std::string& key, double fallback, double lo, double hi, bool open_lo) {
    const double v = bag_.get_double(key, fallback);
    const bool ok = (open_lo ? v > lo : v >= lo) && v <= hi;
    if (!ok)
      throw UsageError(bag_.context() + ": '" + key + "' = " + std::to_string(v) + " must be in " +
                       (open_lo ? "(" : "[") + std::to_string(lo) + ", " + std::to_string(hi) +
                       "]");
    return v;
  }

  int material(const std::string& name, double rho, double emission = 0.0) {
    scene_.materials.push_back(Material{name, Rgb(rho), Rgb(emission)});
    return int(scene_.materials.size() - 1);
  }

  void polygon(std::vector<Vec3> v, int material, const std::string& origin) {
    scene_.polygons.push_back(Polygon{std::move(v), material, origin});
  }

  // The closed box [0,size]^3 with inward faces, all but the floor (the caller builds it); the
  // ceiling is `ceiling`'s material, the walls `wall`'s.
  void box_without_floor(const std::string& prefix, double s, int wall, int ceiling) {
    const Vec3 c(0.5 * s);
    auto inward = [&](std::vector<Vec3> v, int m, const char* name) {
      const Vec3 n = c - geometry::centroid(v);
      polygon(facing(std::move(v), n), m, prefix + name);
    };
    inward(rect_y(0, s, 0, s, s, false), ceiling, "ceiling");
    inward({{0, 0, s}, {s, 0, s}, {s, s, s}, {0, s, s}}, wall, "back");
    inward({{0, 0, 0}, {s, 0, 0}, {s, s, 0}, {0, s, 0}}, wall, "front");
    inward({{0, 0, 0}, {0, s, 0}, {0, s, s}, {0, 0, s}}, wall, "left");
    inward({{s, 0, 0}, {s, s, 0}, {s, s, s}, {s, 0, s}}, wall, "right");
  }

  // A camera inside the box near its front wall, looking at the back wall.
  void box_camera(const Vec3& size) {
    Camera camera;
    camera.eye = Vec3(0.5 * size.x, 0.5 * size.y, 0.02 * size.z);
    camera.look_at = Vec3(0.5 * size.x, 0.5 * size.y, size.z);
    camera.vertical_fov_degrees = 100.0;
    scene_.camera = camera;
  }

  Scene take() { return std::move(scene_); }

 private:
  ParamBag& bag_;
  Scene scene_;
};

}  // namespace

// A 4 x 3 x 5 m closed room (x, y up, z) whose only light is a square of side `size` (1 mm)
// hanging `drop` (1 cm) below the centre of the ceiling, facing down, emitting `emission` (1e6,
// so 1 W of radiosity x area). The room's own elements are far larger than the lamp: a hemicube
// or a few rays per room element miss it, while the lamp's own row sees the room well.
Scene make_tiny_light_scene(ParamBag& bag) {
  Builder b(bag);
  const double size = b.number("size", 1e-3, 0.0, 1.0, true);
  const double emission = b.number("emission", 1e6, 0.0, 1e12, true);
  const double rho = b.number("rho", 0.5, 0.0, 1.0, false);
  const double drop = b.number("drop", 1e-2, 0.0, 1.0, true);
  const Vec3 room(4.0, 3.0, 5.0);
  const int wall = b.material("wall", rho);
  const int lamp = b.material("lamp", rho, emission);
  const Vec3 c = 0.5 * room;
  auto inward = [&](std::vector<Vec3> v, const char* name) {
    const Vec3 n = c - geometry::centroid(v);
    b.polygon(facing(std::move(v), n), wall, std::string("tiny-light/") + name);
  };
  inward(rect_y(0, room.x, 0, room.z, 0, true), "floor");
  inward(rect_y(0, room.x, 0, room.z, room.y, false), "ceiling");
  inward({{0, 0, room.z}, {room.x, 0, room.z}, {room.x, room.y, room.z}, {0, room.y, room.z}},
         "back");
  inward({{0, 0, 0}, {room.x, 0, 0}, {room.x, room.y, 0}, {0, room.y, 0}}, "front");
  inward({{0, 0, 0}, {0, room.y, 0}, {0, room.y, room.z}, {0, 0, room.z}}, "left");
  inward({{room.x, 0, 0}, {room.x, room.y, 0}, {room.x, room.y, room.z}, {room.x, 0, room.z}},
         "right");
  const double h = 0.5 * size;
  b.polygon(rect_y(c.x - h, c.x + h, c.z - h, c.z + h, room.y - drop, false), lamp,
            "tiny-light/lamp");
  b.box_camera(room);
  return b.take();
}

// The closed unit cube (ceiling emits `emission`, every face reflects `rho`) whose floor is
// three rectangles: a corner square of side c = 1/sqrt(ratio) (area 1/ratio), the rest of its
// row [c,1] x [0,1] (area 1 - c, the big neighbour) and the strip [0,c] x [c,1] (area c - c^2,
// aspect c). Neighbouring polygons' areas differ by ratio (1e6: 1 mm^2 beside ~1 m^2).
Scene make_area_ratio_scene(ParamBag& bag) {
  Builder b(bag);
  const double ratio = b.number("ratio", 1e6, 1.0, 1e12, false);
  const double rho = b.number("rho", 0.9, 0.0, 1.0, false);
  const double emission = b.number("emission", 1.0, 0.0, 1e12, true);
  const int wall = b.material("wall", rho);
  const int light = b.material("light", rho, emission);
  b.box_without_floor("area-ratio/", 1.0, wall, light);
  const double c = 1.0 / std::sqrt(ratio);
  b.polygon(rect_y(0, c, 0, c, 0, true), wall, "area-ratio/floor-corner");
  b.polygon(rect_y(c, 1, 0, 1, 0, true), wall, "area-ratio/floor-main");
  if (c < 1.0) b.polygon(rect_y(0, c, c, 1, 0, true), wall, "area-ratio/floor-strip");
  b.box_camera(Vec3(1.0));
  return b.take();
}

// The closed unit cube (ceiling emits, rho everywhere) whose floor is `count` sliver triangles
// fanned from the corner (0,0,0) to the far edge x = 1, each of height `aspect` there (so its
// shortest altitude over its longest edge is about `aspect`), and one quadrilateral covering the
// rest of the floor.
Scene make_slivers_scene(ParamBag& bag) {
  Builder b(bag);
  const double aspect = b.number("aspect", 1e-4, 0.0, 0.1, true);
  const long long count = bag.get_int("count", 4);
  if (count < 1 || count * aspect > 0.5)
    throw UsageError(bag.context() + ": 'count' must be >= 1 with count x aspect <= 0.5");
  const double rho = b.number("rho", 0.9, 0.0, 1.0, false);
  const double emission = b.number("emission", 1.0, 0.0, 1e12, true);
  const int wall = b.material("wall", rho);
  const int light = b.material("light", rho, emission);
  b.box_without_floor("slivers/", 1.0, wall, light);
  const Vec3 up(0, 1, 0);
  for (long long k = 0; k < count; ++k) {
    b.polygon(facing({{0, 0, 0}, {1, 0, double(k) * aspect}, {1, 0, double(k + 1) * aspect}}, up),
              wall, "slivers/floor-sliver-" + std::to_string(k));
  }
  b.polygon(facing({{0, 0, 0}, {1, 0, double(count) * aspect}, {1, 0, 1}, {0, 0, 1}}, up), wall,
            "slivers/floor-rest");
  b.box_camera(Vec3(1.0));
  return b.take();
}

// The closed unit cube (ceiling emits, rho everywhere) with a "rug": the square
// [0.5 - w/2, 0.5 + w/2]^2 (w = `rug`, 0.5) lying on the floor at height `lift` (0: coplanar, an
// overlap), facing up, reflecting `rug_rho` (0.5). Physically the floor under the rug is hidden;
// the input does not say so, and with lift = 0 the floor and the rug both see the room through
// the same area: the rows of F of what looks at the floor sum above 1.
Scene make_overlap_scene(ParamBag& bag) {
  Builder b(bag);
  const double w = b.number("rug", 0.5, 0.0, 1.0, true);
  const double lift = b.number("lift", 0.0, 0.0, 0.5, false);
  const double rho = b.number("rho", 0.9, 0.0, 1.0, false);
  const double rug_rho = b.number("rug_rho", 0.5, 0.0, 1.0, false);
  const double emission = b.number("emission", 1.0, 0.0, 1e12, true);
  const int wall = b.material("wall", rho);
  const int light = b.material("light", rho, emission);
  const int rug = b.material("rug", rug_rho);
  b.box_without_floor("overlap/", 1.0, wall, light);
  b.polygon(rect_y(0, 1, 0, 1, 0, true), wall, "overlap/floor");
  b.polygon(rect_y(0.5 - 0.5 * w, 0.5 + 0.5 * w, 0.5 - 0.5 * w, 0.5 + 0.5 * w, lift, true), rug,
            "overlap/rug");
  b.box_camera(Vec3(1.0));
  return b.take();
}

// Two unit squares, [0,1]^2 at y = 0 facing up (emitting `emission`) and at y = gap facing down,
// both reflecting `rho` (0.9); open at the sides, so light escapes through the gap's rim and the
// rows of F sum to 1 - O(gap). At gap = 1e-3 the pair's form factor is ~0.999 and its integrand
// is nearly singular along the whole face: the hardest case for quadrature.
Scene make_near_pair_scene(ParamBag& bag) {
  Builder b(bag);
  const double gap = b.number("gap", 1e-3, 0.0, 10.0, true);
  const double rho = b.number("rho", 0.9, 0.0, 1.0, false);
  const double emission = b.number("emission", 1.0, 0.0, 1e12, true);
  const int plate = b.material("plate", rho);
  const int light = b.material("light", rho, emission);
  b.polygon(rect_y(0, 1, 0, 1, 0, true), light, "near-pair/lower");
  b.polygon(rect_y(0, 1, 0, 1, gap, false), plate, "near-pair/upper");
  Camera camera;  // from the side, looking into the gap
  camera.eye = Vec3(0.5, 0.5 * gap, -1.0);
  camera.look_at = Vec3(0.5, 0.5 * gap, 0.5);
  camera.vertical_fov_degrees = 40.0;
  Scene scene = b.take();
  scene.camera = camera;
  return scene;
}

}  // namespace radlab
