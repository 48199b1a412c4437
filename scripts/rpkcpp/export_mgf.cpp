// export_mgf: writes a scene as radlab loads it — after validation: coincident overlaps removed,
// non-convex and non-planar faces split (docs/scenes.md) — as a flat MGF file, one face per
// radlab polygon in radlab's polygon order. At the default mesh a polygon is one element, so a
// program that reads the file solves the geometry radlab solves, element for element: this is
// how RenderPark (rpkCpp) is given radlab's hospital for docs/peers.md (the file as published
// has its furniture twice, which radlab removes and RenderPark keeps).
//
// Colours: each material's reflectance and emission (linear RGB) go back to CIE (x, y, Y) by
// radlab's own inverse conversion (scene/cie_colour.h), written as `c` + `cxy` and `rd` / `ed`
// = Y. A reader with the same conversion gets radlab's RGB back exactly; RenderPark's differs
// off the neutral point (docs/peers.md gives by how much).
//
// Build against the installed package (docs/library.md), outside the tree:
//   cmake --install build --prefix P
//   cmake -S scripts/rpkcpp -B build-rpkcpp -DCMAKE_PREFIX_PATH=P && cmake --build build-rpkcpp
//   build-rpkcpp/export_mgf SCENE OUT.mgf [MGF_INCLUDE_ROOT]
#include <cstdio>
#include <exception>
#include <string>

#include "scene/cie_colour.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"

namespace {

void write_colour(std::FILE* out, const radlab::Rgb& rgb, const char* key) {
  const radlab::cie::Xyz xyz = radlab::cie::rgb_to_xyz(rgb);
  const double sum = xyz.x + xyz.y + xyz.z;
  if (sum > 0) std::fprintf(out, "\tc\n\t\tcxy %.9g %.9g\n", xyz.x / sum, xyz.y / sum);
  std::fprintf(out, "\t%s %.9g\n", key, xyz.y);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: export_mgf SCENE OUT.mgf [MGF_INCLUDE_ROOT]\n");
    return 2;
  }
  try {
    if (argc == 4) radlab::set_mgf_include_root(argv[3]);
    const radlab::LoadedScene loaded = radlab::load_scene(argv[1], false);
    const radlab::Scene& scene = loaded.scene;
    const radlab::Mesh mesh = radlab::build_mesh(scene, radlab::MeshOptions{});
    if (mesh.size() != scene.polygons.size()) {
      std::fprintf(stderr, "%s: %zu elements from %zu polygons; the export needs one each\n",
                   argv[1], mesh.size(), scene.polygons.size());
      return 3;
    }
    std::FILE* out = std::fopen(argv[2], "w");
    if (out == nullptr) {
      std::fprintf(stderr, "%s: cannot be written\n", argv[2]);
      return 3;
    }
    for (size_t m = 0; m < scene.materials.size(); ++m) {
      std::fprintf(out, "m mat%zu =\n", m);
      write_colour(out, scene.materials[m].reflectance, "rd");
      if (scene.materials[m].emits()) write_colour(out, scene.materials[m].emission, "ed");
    }
    size_t vertex = 0;
    for (const radlab::Polygon& polygon : scene.polygons) {
      std::fprintf(out, "m mat%d\n", polygon.material);
      std::string face = "f";
      for (const radlab::Vec3& p : polygon.vertices) {
        std::fprintf(out, "v v%zu =\n\tp %.17g %.17g %.17g\n", vertex, p.x, p.y, p.z);
        face += " v" + std::to_string(vertex++);
      }
      std::fprintf(out, "%s\n", face.c_str());
    }
    if (std::fclose(out) != 0) {
      std::fprintf(stderr, "%s: write failed\n", argv[2]);
      return 3;
    }
    std::fprintf(stderr, "%s: %zu polygons written to %s\n", argv[1], scene.polygons.size(),
                 argv[2]);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "export_mgf: %s\n", e.what());
    return 3;
  }
}
