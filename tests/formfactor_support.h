// Fixtures shared by the form-factor tests (tests/formfactor/): Howell's
// catalogue of unit-square configuration factors and the pair helpers that measure against it.
#pragma once

#include <vector>

#include "formfactor/methods/raycast.h"
#include "scene/mesh.h"
#include "scene/scene.h"
#include "tests/test_support.h"

namespace radlab::testing {

// Howell's catalogue C-11: parallel unit squares facing each other at distance 1.
inline constexpr double kParallelUnitSquaresAt1 = 0.199824895698;
// C-14 with a common edge at 90 degrees: unit squares.
inline constexpr double kPerpendicularUnitSquares = 0.200043776075;

inline std::vector<Vec3> square_x0() {  // x = 0 plane, y,z in [0,1], facing +x
  return {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}};
}

inline double raycast_pair(const Scene& scene, RaycastOptions options = {}) {
  Mesh mesh = build_mesh(scene, {});
  RaycastFormFactors ff(scene, mesh, options);
  RowCost cost;
  return ff.pair(0, 1, cost);
}

// ---------------------------------------------------------------------------------------------
// The catalogue (Howell, "A catalog of radiation heat transfer configuration factors"): unit
// squares. Each value is quoted to 12 significant digits, so 5e-13 absolute is its own rounding.

struct CatalogueCase {
  const char* name;
  std::vector<Vec3> emitter, receiver;
  double value;
};

inline std::vector<CatalogueCase> catalogue() {
  return {
      {"parallel_d0.1", square_z(0.0, true), square_z(0.1, false), 0.826994522397},
      {"parallel_d0.5", square_z(0.0, true), square_z(0.5, false), 0.415253283577},
      {"parallel_d1", square_z(0.0, true), square_z(1.0, false), 0.199824895698},
      {"parallel_d2", square_z(0.0, true), square_z(2.0, false), 0.0685895888186},
      {"perpendicular", square_z(0.0, true), square_x0(), kPerpendicularUnitSquares},
  };
}

// The form factor between the two polygons of a two-polygon scene meshed k x k: the area-weighted
// sum of the element rows of the emitter's elements over the receiver's elements.
inline double polygon_pair(const FormFactorMethod& method, const Mesh& mesh, RowCost& cost) {
  std::vector<double> row(mesh.size());
  double f = 0.0, area = 0.0;
  for (size_t e = 0; e < mesh.size(); ++e) {
    if (mesh.polygon[e] != 0) continue;
    method.row(e, row, cost);
    for (size_t j = 0; j < mesh.size(); ++j)
      if (mesh.polygon[j] == 1) f += mesh.area[e] * row[j];
    area += mesh.area[e];
  }
  return f / area;
}

}  // namespace radlab::testing
