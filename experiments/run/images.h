// Images of a run at chosen checkpoints: the display solution (EXR + tone-mapped PNG) seen from
// the scene's camera (or a default view), and error maps against the reference — Cohen 1988's
// pseudo-colour (grey exact, blue under-estimate, red over-estimate) and the signed p-error of
// Wu & Wang — as EXR and PNG. scripts/contact_sheet.py tiles them into a methods x steps sheet.
#pragma once

#include <memory>
#include <string>

#include "experiments/problem/problem.h"
#include "experiments/sweep/experiment_spec.h"
#include "render/exr_io.h"
#include "render/image.h"
#include "solvers/solver.h"

namespace radlab {

class EmbreeScene;

// The EXR header attributes of a run's image: radlab.run_id, .scene, .solver, .step, .rows,
// .git_sha and .version.
ExrAttributes run_provenance(const std::string& run_id, const std::string& scene,
                             const std::string& solver, long long step, unsigned long long rows);

class ImageMaker {
 public:
  ImageMaker(const Problem& problem, const ImageSpec& spec);
  ~ImageMaker();
  ImageMaker(const ImageMaker&) = delete;
  ImageMaker& operator=(const ImageMaker&) = delete;

  // Writes STEM_stepNNNNNN{.exr,.png,_cohen.exr,_cohen.png,_perror.exr,_perror.png}; the EXR
  // files carry `provenance` as header attributes (run_provenance()).
  void save(const Solver& solver, long long step, const std::string& stem,
            const ExrAttributes& provenance) const;

  // The reference rendered once, with the exposure every other image of this problem uses (so
  // brightness compares across methods and steps).
  double exposure() const { return exposure_; }

 private:
  const Problem& problem_;
  ImageSpec spec_;
  std::unique_ptr<EmbreeScene> embree_;
  Camera camera_;
  double exposure_ = 1.0;
};

}  // namespace radlab
