// `radlab scenes [SCENE]`: lists the built-in scenes and their parameters, or describes one scene
// (polygons, elements, emitters, bounds).
#include <cstdio>
#include <glm/common.hpp>

#include "cli/cli_common.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/scene_loader.h"

namespace radlab::cli {

void add_scenes_command(CLI::App& app) {
  auto* command = app.add_subcommand("scenes", "list the built-in scenes, or describe one scene");
  auto options = std::make_shared<SceneOptions>();
  command->add_option("scene", options->scene,
                      "a scene to describe (builtin:NAME, or an .obj or .mgf file)");
  add_mesh_options(*command, *options);
  command->callback([options]() {
    if (options->scene.empty()) {
      std::printf("Built-in scenes (use as builtin:NAME or builtin:NAME:key=value,...):\n\n");
      for (const BuiltinScene& s : builtin_scenes()) {
        std::printf("  %-14s %s\n", s.name.c_str(), s.summary.c_str());
        for (const BuiltinParameter& p : s.parameters)
          std::printf("      %-12s default %-6s %s\n", p.name.c_str(), p.default_value.c_str(),
                      p.help.c_str());
      }
      std::printf(
          "\nFiles: .obj with .mtl (Kd = reflectance, Ke = emission), or .mgf (Ward's Materials "
          "and Geometry Format, as in the RenderPark scenes; docs/scenes.md).\n");
      return;
    }
    LoadedScene loaded = load_scene(options->scene);
    const Scene& scene = loaded.scene;
    MeshOptions mesh_options{options->subdiv, options->element_size};
    Mesh mesh = build_mesh(scene, mesh_options);
    Vec3 lo(1e300), hi(-1e300);
    for (const Polygon& p : scene.polygons)
      for (const Vec3& v : p.vertices) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
      }
    std::printf("scene      %s\n", scene.name.c_str());
    std::printf("polygons   %zu (%d dropped, %d split on loading)\n", scene.polygons.size(),
                loaded.report.dropped, loaded.report.triangulated);
    std::printf("elements   %zu (subdiv %d, element size %g)\n", mesh.size(), options->subdiv,
                options->element_size);
    std::printf("emitters   %d polygons\n", scene.emitter_count());
    std::printf("materials  %zu, %s\n", scene.materials.size(),
                scene.is_grey() ? "grey (1 channel)" : "RGB (3 channels)");
    std::printf("area       %.9g m^2\n", mesh.total_area);
    std::printf("bounds     [%g, %g, %g] - [%g, %g, %g] m\n", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    std::printf("camera     %s\n", scene.camera ? "from the scene" : "default view");
  });
}

}  // namespace radlab::cli
