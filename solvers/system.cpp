#include "solvers/system.h"

#include <algorithm>
#include <stdexcept>

namespace radlab {

System::System(const Scene& scene, const Mesh& mesh, const FormFactorMatrix& matrix)
    : scene_(scene), mesh_(mesh), matrix_(&matrix) {
  init(scene);
}

System::System(const Scene& scene, const Mesh& mesh, const FormFactorMethod& method)
    : scene_(scene), mesh_(mesh), method_(&method) {
  init(scene);
}

System::System(const Scene& scene, const Mesh& mesh, const FormFactorMethod& gather,
               const Patches& patches, const RowMatrix& rows)
    : scene_(scene), mesh_(mesh), method_(&gather), patch_rows_(&rows), shooters_(&patches) {
  if (patches.elements() != mesh.size() || rows.rows() != patches.size() ||
      rows.columns() != mesh.size())
    throw std::invalid_argument("System: two-level parts of different sizes");
  init(scene);
}

void System::init(const Scene& scene) {
  const size_t n = mesh_.size();
  const int channels = scene.is_grey() ? 1 : 3;
  area_ = mesh_.area;
  if (!shooters_) {
    own_shooters_ = element_patches(mesh_);
    shooters_ = &own_shooters_;
  }
  inverse_area_.resize(n);
  total_area_ = 0.0;
  for (size_t i = 0; i < n; ++i) {
    inverse_area_[i] = 1.0 / area_[i];
    total_area_ += area_[i];
  }
  reflectance_ = Radiosity(channels, n);
  emission_ = Radiosity(channels, n);
  for (size_t i = 0; i < n; ++i) {
    const Material& m = scene.materials[size_t(scene.polygons[mesh_.polygon[i]].material)];
    for (int c = 0; c < channels; ++c) {
      reflectance_.at(c, i) = m.reflectance[c];
      emission_.at(c, i) = m.emission[c];
      max_reflectance_ = std::max(max_reflectance_, m.reflectance[c]);
    }
  }
}

}  // namespace radlab
