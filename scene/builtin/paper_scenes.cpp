#include "scene/builtin/paper_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <glm/geometric.hpp>
#include <numbers>

#include "core/error.h"
#include "core/limits.h"
#include "core/text.h"

namespace radlab {
namespace {

// Faces of an axis-aligned box, for leaving some out (those resting on the floor, against a
// wall or under another object: they would receive no light and only cost elements).
enum Face : unsigned {
  kXMin = 1u << 0,
  kXMax = 1u << 1,
  kBottom = 1u << 2,  // y min
  kTop = 1u << 3,     // y max
  kZMin = 1u << 4,
  kZMax = 1u << 5,
};

using MaterialOf = std::function<int(const Vec3&)>;

// True when p's x and z lie in the rectangle [x0, x1] x [z0, z1].
bool in_xz(const Vec3& p, double x0, double x1, double z0, double z1) {
  return p.x >= x0 && p.x <= x1 && p.z >= z0 && p.z <= z1;
}

// Builds a scene of axis-aligned boxes and rooms whose faces are split into patches of about
// `patch` metres (at least one per face edge).
class Builder {
 public:
  Builder(ParamBag& bag, double patch) {
    patch_ = bag.get_double("patch", patch);
    if (!(patch_ > 0)) throw UsageError(bag.context() + ": 'patch' must be > 0");
    light_scale_ = bag.get_double("light_scale", 1.0);
    if (!(light_scale_ > 0)) throw UsageError(bag.context() + ": 'light_scale' must be > 0");
    rho_scale_ = bag.get_double("rho_scale", 1.0);
    if (!(rho_scale_ >= 0)) throw UsageError(bag.context() + ": 'rho_scale' must be >= 0");
    context_ = bag.context();
  }

  int material(const std::string& name, Rgb rho, Rgb emission = Rgb(0.0)) {
    rho *= rho_scale_;
    if (rho.x > 1 || rho.y > 1 || rho.z > 1)
      throw UsageError(context_ + ": 'rho_scale' = " + std::to_string(rho_scale_) +
                       " makes the reflectance of '" + name + "' exceed 1");
    scene_.materials.push_back(Material{name, rho, light_scale_ * emission});
    return int(scene_.materials.size() - 1);
  }

  // Patches along an edge, counted in double before it becomes an int (patch=1e-300 asks for
  // 10^300): more than the polygon limit along one edge is refused here, the total in grid().
  int pieces(double length) const {
    const double n = std::max(1.0, std::round(length / patch_));
    if (!(n <= limits().polygons))
      check_limit("polygons", n,
                  context_ + ": 'patch' = " + text::format_double(patch_) + " along a " +
                      text::format_double(length) + " m edge makes");
    if (n > 1e9) throw InputError(context_ + ": 'patch' is too small for 32-bit patch counts");
    return int(n);
  }

  // The parallelogram o + s u + t v, s, t in [0, 1], as nu x nv patches whose front side faces
  // along `facing`; material_of(centre) picks each patch's material from its centre.
  void grid(const Vec3& o, Vec3 u, Vec3 v, int nu, int nv, const Vec3& facing,
            const MaterialOf& material_of, const std::string& name) {
    check_limit("polygons", double(scene_.polygons.size()) + double(nu) * double(nv),
                context_ + ": 'patch' = " + text::format_double(patch_) + " makes");
    if (glm::dot(glm::cross(u, v), facing) < 0) {
      std::swap(u, v);
      std::swap(nu, nv);
    }
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        auto at = [&](double a, double b) { return o + u * (a / nu) + v * (b / nv); };
        scene_.polygons.push_back(
            Polygon{{at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)},
                    material_of(at(i + 0.5, j + 0.5)),
                    name + "[" + std::to_string(i) + "," + std::to_string(j) + "]"});
      }
  }

  // One face of the box [lo, hi]: axis a (0 x, 1 y, 2 z), on the high side or the low side,
  // facing out of the box (or into it, for rooms).
  void face(const Vec3& lo, const Vec3& hi, int a, bool high, bool outward,
            const MaterialOf& material_of, const std::string& name) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    Vec3 o = lo;
    o[a] = high ? hi[a] : lo[a];
    Vec3 u(0.0), v(0.0), facing(0.0);
    u[b] = hi[b] - lo[b];
    v[c] = hi[c] - lo[c];
    facing[a] = (high == outward) ? 1.0 : -1.0;
    grid(o, u, v, pieces(u[b]), pieces(v[c]), facing, material_of, name);
  }

  // A solid box, faces outward, leaving out the faces in `skip`.
  void box(const Vec3& lo, const Vec3& hi, int material, const std::string& name,
           unsigned skip = kBottom) {
    static const char* names[6] = {"xmin", "xmax", "bottom", "top", "zmin", "zmax"};
    for (int f = 0; f < 6; ++f) {
      if (skip & (1u << f)) continue;
      face(
          lo, hi, f / 2, f % 2 == 1, true, [material](const Vec3&) { return material; },
          name + "/" + names[f]);
    }
  }

  // The room [lo, hi], faces inward. surface_of(centre) may give a patch a material other than
  // the floor's, ceiling's or walls' (luminaires set into the ceiling, a door); -1 keeps it.
  void room(const Vec3& lo, const Vec3& hi, int floor, int ceiling, int walls,
            const std::function<int(const Vec3&)>& surface_of, const std::string& name) {
    static const char* names[6] = {"wall-xmin", "wall-xmax", "floor",
                                   "ceiling",   "wall-zmin", "wall-zmax"};
    for (int f = 0; f < 6; ++f) {
      const int base = f == 2 ? floor : (f == 3 ? ceiling : walls);
      face(
          lo, hi, f / 2, f % 2 == 1, false,
          [&](const Vec3& c) {
            const int m = surface_of(c);
            return m >= 0 ? m : base;
          },
          name + "/" + names[f]);
    }
  }

  Scene finish(const Camera& camera) {
    scene_.camera = camera;
    return std::move(scene_);
  }

 private:
  double patch_;
  double light_scale_ = 1.0;
  double rho_scale_ = 1.0;
  std::string context_;
  Scene scene_;
};

Camera look(const Vec3& eye, const Vec3& at, double fov) {
  Camera c;
  c.eye = eye;
  c.look_at = at;
  c.up = Vec3(0, 1, 0);
  c.vertical_fov_degrees = fov;
  return c;
}

// A desk: a top slab on two side panels with a modesty panel, its back against a wall at z = back
// (the desk extends towards -z), x from x0 to x1.
void desk(Builder& b, double x0, double x1, double back, double depth, int wood, int panel,
          const std::string& name) {
  const double top = 0.72, t = 0.04;
  b.box({x0, top, back - depth}, {x1, top + t, back}, wood, name + "/top", kZMax);
  b.box({x0, 0, back - depth + 0.05}, {x0 + t, top, back}, panel, name + "/left",
        kBottom | kTop | kZMax);
  b.box({x1 - t, 0, back - depth + 0.05}, {x1, top, back}, panel, name + "/right",
        kBottom | kTop | kZMax);
  b.box({x0 + t, 0.25, back - 0.12}, {x1 - t, top, back - 0.08}, panel, name + "/modesty",
        kTop | kXMin | kXMax);
}

// An office chair as boxes: pedestal, seat and back; the sitter faces +z (a desk behind it at
// larger z) unless `facing_minus_z`.
void chair(Builder& b, double cx, double cz, int fabric, int base, const std::string& name,
           bool facing_minus_z = false) {
  const double s = 0.23;
  b.box({cx - 0.04, 0, cz - 0.04}, {cx + 0.04, 0.42, cz + 0.04}, base, name + "/pedestal",
        kBottom | kTop);
  b.box({cx - s, 0.42, cz - s}, {cx + s, 0.5, cz + s}, fabric, name + "/seat", 0);
  const double z0 = facing_minus_z ? cz + s : cz - s - 0.07;
  b.box({cx - s, 0.5, z0}, {cx + s, 0.95, z0 + 0.07}, fabric, name + "/back", 0);
}

}  // namespace

// Cohen et al. 1988, figure 6: two office cubicles side by side against the back wall of a
// closed room, separated and fronted by fabric partitions (1.6 m), each with a desk against the
// back wall, a monitor, a chair and a filing cabinet, lit by fluorescent luminaires set into the
// ceiling grid (two over each cubicle, one over the aisle before each).
Scene make_office_scene(ParamBag& bag) {
  Builder b(bag, 0.6);
  const int wall = b.material("wall", {0.72, 0.70, 0.64});
  const int accent = b.material("accent-wall", {0.45, 0.55, 0.70});
  const int ceiling = b.material("ceiling", Rgb(0.80));
  const int carpet = b.material("carpet", {0.22, 0.25, 0.32});
  const int light = b.material("luminaire", Rgb(0.80), {12.0, 11.5, 10.0});
  const int fabric = b.material("partition", {0.55, 0.45, 0.32});
  const int wood = b.material("desk", {0.55, 0.37, 0.20});
  const int panel = b.material("desk-panel", {0.35, 0.30, 0.26});
  const int red = b.material("chair-red", {0.60, 0.12, 0.10});
  const int blue = b.material("chair-blue", {0.12, 0.20, 0.55});
  const int metal = b.material("metal", Rgb(0.45));
  const int dark = b.material("monitor", Rgb(0.12));

  const double width = 5.4;  // two cubicles of 2.7 m
  const Vec3 lo(0, 0, 0), hi(width, 2.6, 4.2);
  b.room(
      lo, hi, carpet, ceiling, wall,
      [&](const Vec3& c) {
        if (c.y == hi.y) {  // luminaires over each desk and over the aisle before each
          for (double x0 : {0.6, width - 1.4})
            if (in_xz(c, x0, x0 + 0.8, 3.0, 4.0) || in_xz(c, x0, x0 + 0.8, 0.6, 1.4)) return light;
        }
        return c.x == lo.x ? accent : -1;
      },
      "office");
  // Partitions: between the cubicles (to the back wall) and in front of each (openings at the
  // aisle end).
  const double ph = 1.6, pz = 2.0, mid = 0.5 * width;
  b.box({mid - 0.03, 0, pz}, {mid + 0.03, ph, hi.z}, fabric, "partition-middle", kBottom | kZMax);
  b.box({0.0, 0, pz - 0.03}, {1.8, ph, pz + 0.03}, fabric, "partition-a", kBottom | kXMin);
  b.box({mid + 0.03, 0, pz - 0.03}, {mid + 1.8, ph, pz + 0.03}, fabric, "partition-b", kBottom);
  // Furniture of cubicle A (x 0..2.7) and cubicle B, mirrored.
  for (int c = 0; c < 2; ++c) {
    const std::string n = c == 0 ? "a" : "b";
    auto x = [&](double v) { return c == 0 ? v : width - v; };
    auto span = [&](double v0, double v1, double y0, double y1, double z0, double z1) {
      return std::pair<Vec3, Vec3>{{std::min(x(v0), x(v1)), y0, z0},
                                   {std::max(x(v0), x(v1)), y1, z1}};
    };
    desk(b, std::min(x(0.3), x(1.7)), std::max(x(0.3), x(1.7)), hi.z, 0.8, wood, panel,
         "desk-" + n);
    auto [mlo, mhi] = span(0.8, 1.2, 0.76, 1.12, 3.80, 4.05);
    b.box(mlo, mhi, dark, "monitor-" + n, kBottom);
    auto [klo, khi] = span(0.75, 1.25, 0.76, 0.79, 3.50, 3.68);
    b.box(klo, khi, dark, "keyboard-" + n, kBottom);
    chair(b, x(1.0), 3.0, c == 0 ? red : blue, metal, "chair-" + n);
    auto [flo, fhi] = span(2.10, 2.62, 0.0, 0.72, 3.50, 4.15);
    b.box(flo, fhi, metal, "cabinet-" + n, kBottom);
  }
  return b.finish(look({0.5 * width, 2.5, 0.1}, {0.5 * width, 0.2, 3.4}, 80.0));
}

// Wu & Wang 2002, example B: "a simple environment of a room". A closed room with one ceiling
// luminaire, coloured walls (so the three channels converge differently, as their per-channel
// figures show), a table with four legs, a low cabinet and a box seat.
Scene make_room_scene(ParamBag& bag) {
  Builder b(bag, 0.55);
  const int white = b.material("white-wall", {0.75, 0.74, 0.70});
  const int blue = b.material("blue-wall", {0.25, 0.35, 0.65});
  const int red = b.material("red-wall", {0.65, 0.22, 0.16});
  const int ceiling = b.material("ceiling", Rgb(0.78));
  const int floor = b.material("wood-floor", {0.45, 0.30, 0.18});
  const int light = b.material("luminaire", Rgb(0.78), {15.0, 14.0, 12.0});
  const int table = b.material("table", {0.60, 0.55, 0.45});
  const int cabinet = b.material("cabinet", {0.20, 0.45, 0.25});
  const int seat = b.material("seat", {0.70, 0.60, 0.20});

  const Vec3 lo(0, 0, 0), hi(5.0, 3.0, 4.0);
  b.room(
      lo, hi, floor, ceiling, white,
      [&](const Vec3& c) {
        if (c.y == hi.y) return in_xz(c, 2.2, 3.2, 1.7, 2.7) ? light : -1;
        if (c.x == lo.x) return blue;
        return c.z == hi.z ? red : -1;
      },
      "room");
  // Table: top slab and four legs.
  const Vec3 t0(1.6, 0.72, 1.4), t1(3.4, 0.76, 2.6);
  b.box(t0, t1, table, "table/top", 0);
  for (int k = 0; k < 4; ++k) {
    const double x = k % 2 == 0 ? t0.x + 0.05 : t1.x - 0.11;
    const double z = k / 2 == 0 ? t0.z + 0.05 : t1.z - 0.11;
    b.box({x, 0, z}, {x + 0.06, t0.y, z + 0.06}, table, "table/leg" + std::to_string(k),
          kBottom | kTop);
  }
  b.box({0.2, 0, 3.5}, {1.8, 0.8, 4.0}, cabinet, "cabinet", kBottom | kZMax);
  b.box({3.6, 0, 0.5}, {4.6, 0.45, 1.1}, seat, "seat", kBottom);
  return b.finish(look({4.6, 1.6, 0.3}, {1.8, 0.8, 3.0}, 65.0));
}

// Wu & Wang 2002, example A: "a closed space of a computer room". Two rows of three
// workstations (desk, monitor, keyboard, tower, chair) facing a whiteboard on the front wall,
// six ceiling luminaires, a door in a side wall.
Scene make_computer_room_scene(ParamBag& bag) {
  Builder b(bag, 0.9);
  const int wall = b.material("wall", {0.70, 0.70, 0.66});
  const int ceiling = b.material("ceiling", Rgb(0.80));
  const int floor = b.material("floor", {0.30, 0.32, 0.30});
  const int light = b.material("luminaire", Rgb(0.80), {14.0, 14.0, 13.0});
  const int board = b.material("whiteboard", Rgb(0.85));
  const int door = b.material("door", {0.50, 0.33, 0.18});
  const int desk_top = b.material("desk", {0.62, 0.58, 0.50});
  const int desk_side = b.material("desk-panel", {0.40, 0.40, 0.42});
  const int beige = b.material("computer", {0.70, 0.66, 0.55});
  const int screen = b.material("screen", Rgb(0.08));
  const int chair_mat = b.material("chair", {0.15, 0.25, 0.50});
  const int metal = b.material("metal", Rgb(0.45));

  const Vec3 lo(0, 0, 0), hi(8.0, 3.0, 6.0);
  // The front wall, with the whiteboard, is z = 0.
  b.room(
      lo, hi, floor, ceiling, wall,
      [&](const Vec3& c) {
        if (c.y == hi.y) {  // a luminaire over each workstation
          for (double x0 : {1.1, 3.45, 5.8})
            for (double z0 : {1.5, 3.7})
              if (in_xz(c, x0, x0 + 0.9, z0, z0 + 1.0)) return light;
          return -1;
        }
        if (c.z == lo.z && c.x > 2.5 && c.x < 5.5 && c.y > 0.9 && c.y < 2.1) return board;
        if (c.x == hi.x && c.z > 4.0 && c.z < 5.0 && c.y < 2.1) return door;
        return -1;
      },
      "computer-room");
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 3; ++col) {
      const std::string n = std::to_string(row) + std::to_string(col);
      const double x0 = 0.8 + 2.35 * col, x1 = x0 + 1.5;
      const double z0 = 1.6 + 2.2 * row, z1 = z0 + 0.75;  // desk, users face -z (the board)
      b.box({x0, 0.72, z0}, {x1, 0.76, z1}, desk_top, "desk" + n + "/top", 0);
      b.box({x0, 0, z0}, {x0 + 0.04, 0.72, z1}, desk_side, "desk" + n + "/left", kBottom | kTop);
      b.box({x1 - 0.04, 0, z0}, {x1, 0.72, z1}, desk_side, "desk" + n + "/right", kBottom | kTop);
      const double cx = 0.5 * (x0 + x1);
      // Monitor near the desk's far edge, its screen towards the user (+z).
      b.box({cx - 0.22, 0.76, z0 + 0.05}, {cx + 0.22, 1.14, z0 + 0.40}, beige, "monitor" + n,
            kBottom);
      b.box({cx - 0.20, 0.80, z0 + 0.40}, {cx + 0.20, 1.10, z0 + 0.41}, screen, "screen" + n,
            kBottom | kZMin);
      b.box({cx - 0.25, 0.76, z0 + 0.45}, {cx + 0.25, 0.79, z0 + 0.62}, beige, "keyboard" + n,
            kBottom);
      b.box({x1 - 0.30, 0, z0 + 0.10}, {x1 - 0.10, 0.45, z0 + 0.55}, beige, "tower" + n, kBottom);
      chair(b, cx, z1 + 0.35, chair_mat, metal, "chair" + n, true);
    }
  return b.finish(look({7.6, 2.2, 5.7}, {3.5, 0.8, 1.5}, 65.0));
}

}  // namespace radlab
