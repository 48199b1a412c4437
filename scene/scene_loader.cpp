#include "scene/scene_loader.h"

#include <filesystem>

#include "core/error.h"
#include "core/text.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/readers/mgf_reader.h"
#include "scene/readers/obj_reader.h"

namespace radlab {
namespace {

std::string& include_root() {
  static std::string folder;
  return folder;
}

}  // namespace

void set_mgf_include_root(const std::string& folder) {
  include_root() = folder;
}

namespace {

// The scene as its reader returns it, before validation. `print`: MGF's summarised warnings;
// `quiet`: none at all (OBJ's unknown MTL statements are warned about otherwise).
Scene read_scene_file(const std::string& spec, bool print, bool quiet) {
  const std::string extension = text::to_lower(std::filesystem::path(spec).extension().string());
  if (!std::filesystem::exists(spec)) throw InputError(spec + ": no such file");
  std::error_code ec;
  if ((extension == ".obj" || extension == ".mgf") && !std::filesystem::is_regular_file(spec, ec))
    throw InputError(spec + ": not a regular file");
  Scene scene;
  if (extension == ".obj") {
    ObjOptions options;
    options.include_root = include_root();
    options.print_warnings = !quiet;
    scene = read_obj(spec, options);
  } else if (extension == ".mgf") {
    MgfOptions options;
    options.print_warnings = print && !quiet;
    options.include_root = include_root();
    scene = read_mgf(spec, options);
  } else {
    throw InputError(spec + ": unsupported scene format '" + extension +
                     "' (radlab reads .obj with .mtl, .mgf, or builtin:NAME; see `radlab scenes`)");
  }
  scene.name = spec;
  return scene;
}

}  // namespace

std::vector<SourceFile> scene_source_files(const std::string& spec) {
  if (text::starts_with(spec, "builtin:")) return {};
  return read_scene_file(spec, false, true).sources;
}

LoadedScene load_scene(const std::string& spec, bool print, bool keep_overlaps) {
  LoadedScene loaded;
  if (text::starts_with(spec, "builtin:")) {
    loaded.scene = make_builtin_scene(spec.substr(8));
  } else {
    loaded.scene = read_scene_file(spec, print, false);
  }
  loaded.report = validate_scene(loaded.scene, keep_overlaps);
  if (print) print_warnings(loaded.report);
  return loaded;
}

}  // namespace radlab
