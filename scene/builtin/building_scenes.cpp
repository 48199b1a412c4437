#include "scene/builtin/building_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <string>

#include "core/error.h"
#include "core/limits.h"
#include "core/text.h"

namespace radlab {
namespace {

constexpr double kWidth = 12.0;  // footprint, x and z
constexpr double kRoom = 3.0;    // floor to ceiling
constexpr double kSlab = 0.5;    // slab thickness
constexpr double kStorey = kRoom + kSlab;
constexpr double kAtriumLo = 4.0, kAtriumHi = 8.0;  // the void through the slabs, x and z
// Desks: 2 x 1 m blocks from 0.5 to 1 m, two columns beside the atrium, four rows.
constexpr double kDeskX[2] = {1.0, 9.0};
constexpr double kDeskZ[4] = {1.0, 4.5, 8.0, 10.5};

// A patch's material from its box (lo, hi corners).
using MaterialOf = std::function<int(const Vec3&, const Vec3&)>;

struct Materials {
  int wall, ceiling, floor, edge, desk, lamp;
};

class FloorsBuilder {
 public:
  // counting: grid() only counts the patches it would make (for the limit check).
  FloorsBuilder(double patch, const std::string& context, bool counting = false)
      : patch_(patch), context_(context), counting_(counting) {}

  double counted() const { return counted_; }

  Scene& scene() { return scene_; }

  int material(const std::string& name, Rgb rho, Rgb emission = Rgb(0.0)) {
    scene_.materials.push_back(Material{name, rho, emission});
    return int(scene_.materials.size() - 1);
  }

  int pieces(double length) const {
    const double n = std::max(1.0, std::round(length / patch_));
    if (n > 1e6)
      throw UsageError(context_ + ": 'patch' = " + text::format_double(patch_) +
                       " is too small (more than 1e6 patches along one edge)");
    return int(n);
  }

  // The rectangle o + s u + t v (s, t in [0,1]) as patches whose front side faces along
  // `facing`; material_of(box) picks each patch's material.
  void grid(const Vec3& o, Vec3 u, Vec3 v, const Vec3& facing, const MaterialOf& material_of,
            const std::string& name) {
    int nu = pieces(glm::length(u)), nv = pieces(glm::length(v));
    if (counting_) {
      counted_ += double(nu) * double(nv);
      return;
    }
    if (glm::dot(glm::cross(u, v), facing) < 0) {
      std::swap(u, v);
      std::swap(nu, nv);
    }
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        auto at = [&](double a, double b) { return o + u * (a / nu) + v * (b / nv); };
        scene_.polygons.push_back(Polygon{
            {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)},
            material_of(glm::min(at(i, j), at(i + 1, j + 1)), glm::max(at(i, j), at(i + 1, j + 1))),
            name + "[" + std::to_string(i) + "," + std::to_string(j) + "]"});
      }
  }

  // A horizontal rectangle [x0,x1] x [z0,z1] at height y facing up or down.
  void horizontal(double x0, double x1, double z0, double z1, double y, bool up,
                  const MaterialOf& material_of, const std::string& name) {
    grid({x0, y, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, {0, up ? 1.0 : -1.0, 0}, material_of, name);
  }

  // A horizontal surface over the footprint, around the atrium or solid.
  void plate(double y, bool up, bool with_atrium, const MaterialOf& material_of,
             const std::string& name) {
    if (!with_atrium) {
      horizontal(0, kWidth, 0, kWidth, y, up, material_of, name);
      return;
    }
    horizontal(0, kWidth, 0, kAtriumLo, y, up, material_of, name + "-front");
    horizontal(0, kWidth, kAtriumHi, kWidth, y, up, material_of, name + "-back");
    horizontal(0, kAtriumLo, kAtriumLo, kAtriumHi, y, up, material_of, name + "-left");
    horizontal(kAtriumHi, kWidth, kAtriumLo, kAtriumHi, y, up, material_of, name + "-right");
  }

  // The four vertical faces of the box [lo, hi] whose front sides face out of it (outward) or
  // into it.
  void sides(const Vec3& lo, const Vec3& hi, bool outward, int material, const std::string& name) {
    const auto same = [material](const Vec3&, const Vec3&) { return material; };
    const Vec3 dy(0, hi.y - lo.y, 0), dx(hi.x - lo.x, 0, 0), dz(0, 0, hi.z - lo.z);
    const double out = outward ? 1.0 : -1.0;
    grid(lo, dx, dy, {0, 0, -out}, same, name + "/zmin");
    grid({lo.x, lo.y, hi.z}, dx, dy, {0, 0, out}, same, name + "/zmax");
    grid(lo, dz, dy, {-out, 0, 0}, same, name + "/xmin");
    grid({hi.x, lo.y, lo.z}, dz, dy, {out, 0, 0}, same, name + "/xmax");
  }

  void storey(int s, int storeys, const Materials& m) {
    const std::string n = "floors/s" + std::to_string(s);
    const double y0 = s * kStorey, y1 = y0 + kRoom;
    const bool ground = s == 0, roof = s + 1 == storeys;
    plate(
        y0, true, !ground, [&](const Vec3&, const Vec3&) { return m.floor; }, n + "/floor");
    plate(
        y1, false, !roof,
        [&](const Vec3& lo, const Vec3& hi) {
          // A luminaire: a patch lying at least half in a lamp's square, or holding the square's
          // centre (in its half-open box). At the default patch, exactly the square's four
          // patches; at coarse ones, the patch or two around it, so every patch size has lamps.
          const double area = (hi.x - lo.x) * (hi.z - lo.z);
          for (double x0 : kDeskX)
            for (double z0 : kDeskZ) {
              const double cx = x0 + 1.0, cz = z0 + 0.5;
              if (lo.x <= cx && cx < hi.x && lo.z <= cz && cz < hi.z) return m.lamp;
              const double ox = std::min(hi.x, x0 + 1.5) - std::max(lo.x, x0 + 0.5);
              const double oz = std::min(hi.z, z0 + 1.0) - std::max(lo.z, z0);
              if (ox > 0 && oz > 0 && ox * oz >= 0.5 * area) return m.lamp;
            }
          return m.ceiling;
        },
        n + "/ceiling");
    sides({0, y0, 0}, {kWidth, y1, kWidth}, false, m.wall, n + "/wall");
    // The slab's edge around the atrium, between this ceiling and the next floor, faces into the
    // void.
    if (!roof)
      sides({kAtriumLo, y1, kAtriumLo}, {kAtriumHi, y1 + kSlab, kAtriumHi}, false, m.edge,
            n + "/atrium-edge");
    int d = 0;
    for (double x0 : kDeskX)
      for (double z0 : kDeskZ) {
        const std::string dn = n + "/desk" + std::to_string(d++);
        const double lo = y0 + 0.5, hi = y0 + 1.0;
        const auto desk = [&](const Vec3&, const Vec3&) { return m.desk; };
        horizontal(x0, x0 + 2.0, z0, z0 + 1.0, hi, true, desk, dn + "/top");
        horizontal(x0, x0 + 2.0, z0, z0 + 1.0, lo, false, desk, dn + "/bottom");
        sides({x0, lo, z0}, {x0 + 2.0, hi, z0 + 1.0}, true, m.desk, dn);
      }
  }

 private:
  double patch_;
  std::string context_;
  bool counting_ = false;
  double counted_ = 0.0;
  Scene scene_;
};

}  // namespace

Scene make_floors_scene(ParamBag& bag) {
  const long long k = bag.get_int("k", 4, 1, 100000);
  const double patch = bag.get_double("patch", 0.5);
  if (!(patch > 0 && std::isfinite(patch)))
    throw UsageError(bag.context() + ": 'patch' must be a finite number > 0");
  const double light_scale = bag.get_double("light_scale", 1.0);
  if (!(light_scale > 0 && std::isfinite(light_scale)))
    throw UsageError(bag.context() + ": 'light_scale' must be a finite number > 0");
  // Refuse a building past the polygon limit before making it: the exact count, from the ground
  // storey, the roof and k - 2 middle storeys counted without being made.
  Materials m{};
  {
    FloorsBuilder count(patch, bag.context(), true);
    count.storey(0, int(std::min(k, 2LL)), m);
    if (k >= 2) count.storey(1, 2, m);
    const double ends = count.counted();
    FloorsBuilder middle(patch, bag.context(), true);
    if (k >= 3) middle.storey(1, 3, m);
    check_limit("polygons", ends + double(k - 2 > 0 ? k - 2 : 0) * middle.counted(),
                bag.context() + ": k = " + std::to_string(k) +
                    " storeys at 'patch' = " + text::format_double(patch) + " make");
  }
  FloorsBuilder b(patch, bag.context());
  m.wall = b.material("wall", {0.70, 0.68, 0.62});
  m.ceiling = b.material("ceiling", Rgb(0.80));
  m.floor = b.material("floor", {0.35, 0.32, 0.28});
  m.edge = b.material("slab-edge", Rgb(0.55));
  m.desk = b.material("desk", {0.55, 0.40, 0.25});
  m.lamp = b.material("luminaire", Rgb(0.80), light_scale * Rgb(12.0, 11.5, 10.0));
  for (int s = 0; s < int(k); ++s) b.storey(s, int(k), m);
  Scene scene = std::move(b.scene());
  Camera camera;
  const double top = double(k - 1) * kStorey;
  camera.eye = Vec3(0.5, top + 2.5, 0.5);
  camera.look_at = Vec3(6.0, top * 0.5, 6.0);
  camera.up = Vec3(0.0, 1.0, 0.0);
  camera.vertical_fov_degrees = 80.0;
  scene.camera = camera;
  return scene;
}

}  // namespace radlab
