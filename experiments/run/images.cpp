#include "experiments/run/images.h"

#include <cstdio>

#include "core/output_file.h"
#include "core/version.h"
#include "experiments/run/outputs.h"
#include "formfactor/visibility/embree_scene.h"
#include "metrics/error_metrics.h"
#include "render/exr_io.h"
#include "render/false_colour.h"
#include "render/png_io.h"
#include "render/renderer.h"

namespace radlab {

ImageMaker::ImageMaker(const Problem& problem, const ImageSpec& spec)
    : problem_(problem), spec_(spec), embree_(std::make_unique<EmbreeScene>(problem.mesh)) {
  camera_ = problem.scene().camera ? *problem.scene().camera : default_camera(problem.mesh);
  if (problem.reference) {
    Image reference = render_radiosity(problem.mesh, *embree_, problem.reference->B, camera_,
                                       spec.width, spec.height, spec.smooth);
    exposure_ = auto_exposure(reference);
  }
}

ImageMaker::~ImageMaker() = default;

ExrAttributes run_provenance(const std::string& run_id, const std::string& scene,
                             const std::string& solver, long long step, unsigned long long rows) {
  return {{"radlab.run_id", run_id},
          {"radlab.scene", scene},
          {"radlab.solver", solver},
          {"radlab.step", std::to_string(step)},
          {"radlab.rows", std::to_string(rows)},
          {"radlab.git_sha", build_git_sha()},
          {"radlab.version", kVersion}};
}

void ImageMaker::save(const Solver& solver, long long step, const std::string& stem,
                      const ExrAttributes& provenance) const {
  char suffix[32];
  std::snprintf(suffix, sizeof suffix, "_step%06lld", step);
  const std::string base = stem + suffix;
  const Radiosity display = solver.display();
  Image image = render_radiosity(problem_.mesh, *embree_, display, camera_, spec_.width,
                                 spec_.height, spec_.smooth);
  // Each file appears complete or not at all (core/output_file.h).
  auto exr = [&provenance](const std::string& path, const Image& im) {
    write_via_temporary(path, [&](const std::string& temp) { write_exr(temp, im, provenance); });
  };
  auto png_ldr = [](const std::string& path, const Image& im) {
    write_via_temporary(path, [&](const std::string& temp) { write_png_ldr(temp, im); });
  };
  exr(base + ".exr", image);
  write_via_temporary(base + ".png",
                      [&](const std::string& temp) { write_png(temp, image, exposure_); });
  if (!spec_.error_maps || !problem_.reference) return;

  // Per-element relative error of the display solution on the mean of the channels (Cohen
  // measures on the mean of the colour bands); flat shading, so each element shows its own error.
  const size_t n = problem_.mesh.size();
  std::vector<double> relative(n);
  relative_errors(display, problem_.reference->B, problem_.mesh.area, kMeanOfChannels, relative);
  std::vector<glm::dvec3> signed_error(n), cohen(n), perror(n);
  for (size_t i = 0; i < n; ++i) {
    signed_error[i] = glm::dvec3(relative[i]);
    cohen[i] = cohen_error_colour(relative[i]);
    perror[i] = p_error_colour(relative[i]);
  }
  // EXR: the signed relative error itself (for analysis); PNG: the false colours.
  exr(base + "_perror.exr", render_field(problem_.mesh, *embree_, signed_error, camera_,
                                         spec_.width, spec_.height, false));
  png_ldr(base + "_cohen.png",
          render_field(problem_.mesh, *embree_, cohen, camera_, spec_.width, spec_.height, false));
  png_ldr(base + "_perror.png",
          render_field(problem_.mesh, *embree_, perror, camera_, spec_.width, spec_.height, false));
  exr(base + "_cohen.exr",
      render_field(problem_.mesh, *embree_, cohen, camera_, spec_.width, spec_.height, false));
}

}  // namespace radlab
