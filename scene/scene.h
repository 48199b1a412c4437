// The input scene: convex planar polygons with Lambertian materials, in input order.
//
// Units are metres. A polygon's front side is given by its winding (counter-clockwise seen from
// the front, right-hand rule); light leaves and arrives on the front side only.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

namespace radlab {

using Vec3 = glm::dvec3;
using Rgb = glm::dvec3;  // linear RGB, one value per channel

struct Material {
  std::string name;
  Rgb reflectance{0.0};  // diffuse reflectance rho in [0,1] per channel
  Rgb emission{0.0};     // emitted radiosity E >= 0 per channel (W/m^2 or any consistent unit)

  bool emits() const { return emission.x > 0 || emission.y > 0 || emission.z > 0; }
};

struct Polygon {
  std::vector<Vec3> vertices;  // convex, planar, front side counter-clockwise
  int material = 0;            // index into Scene::materials
  std::string origin;          // where it came from, for messages: "box.obj:12", "cornell/floor"
};

// A pinhole camera for images: eye, the point it looks at, up, vertical field of view.
struct Camera {
  Vec3 eye{0.0, 0.0, 1.0};
  Vec3 look_at{0.0};
  Vec3 up{0.0, 1.0, 0.0};
  double vertical_fov_degrees = 40.0;
};

// A file a scene was read from (the scene file, its material libraries, its MGF includes): the
// path as the reader named it and the SHA-256 of the bytes it read. A sweep's identity holds
// them, so that a run on an edited box.mtl is never mixed with runs on the old one.
struct SourceFile {
  std::string path;
  std::string sha256;
  bool operator==(const SourceFile&) const = default;
};

struct Scene {
  std::string name;  // the spec it was loaded from, e.g. "builtin:cube:rho=0.9"
  std::vector<Material> materials;
  std::vector<Polygon> polygons;
  std::optional<Camera> camera;     // the scene's own view, if it has one
  std::vector<SourceFile> sources;  // every file read, in the order first read (none: builtin)

  int emitter_count() const;
  // True when every reflectance and emission is grey (r = g = b): one colour channel suffices.
  bool is_grey() const;
};

}  // namespace radlab
