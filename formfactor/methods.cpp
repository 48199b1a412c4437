// The explicit table of form-factor methods and the factory.
#include "core/error.h"
#include "core/text.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"

namespace radlab {

const std::vector<FormFactorMethodInfo>& form_factor_methods() {
  static const std::vector<FormFactorMethodInfo> table = {
      {"raycast",
       "Lambert point-to-polygon formula integrated over i, times an Embree visibility fraction",
       {{"tolerance", "1e-4: relative quadrature error per pair"},
        {"rays", "16: visibility rays per pair that can be occluded"},
        {"max_rays", "4096: rays for partly occluded pairs with large F (more as F grows)"},
        {"seed", "0: seed of the jittered visibility samples"},
        {"max_order", "8: largest fixed Gauss rule per axis before adaptive subdivision"},
        {"shafts", "true: shaft culling (no rays where nothing can block); false to measure it"}}},
      {"hemicube",
       "Cohen-Greenberg hemicube at each element's centre: z-buffered item buffer, one row per "
       "hemicube (aliasing included)",
       {{"resolution", "150: pixels across the top face (even; side faces R x R/2)"},
        {"weights",
         "midpoint: classic delta form factors; exact: integrated pixel weights (sum 1)"}}},
      {"exact",
       "form factors to ~1e-9 by adaptive quadrature of Lambert's formula; refuses scenes that "
       "can occlude unless visibility=clip (exact shadows) or rays",
       {{"tolerance", "1e-10: relative quadrature error per pair"},
        {"max_depth", "16: subdivision levels of the adaptive rule"},
        {"visibility",
         "refuse: exit 3 if anything can occlude; rays: multiply by raycast V; clip: clip j by "
         "the occluders' shadows at every quadrature point (deterministic)"},
        {"rays", "64: visibility rays per pair that may be blocked (visibility=rays only)"},
        {"seed", "0: seed of the visibility points (visibility=rays only)"},
        {"max_evaluations",
         "20000: evaluations per occluded pair before it stops short of the tolerance and states "
         "its remaining error (visibility=clip only)"}}},
  };
  return table;
}

std::unique_ptr<FormFactorMethod> make_form_factor_method(const std::string& name, ParamBag& bag,
                                                          const Scene& scene, const Mesh& mesh) {
  if (name == "raycast") {
    RaycastOptions options = RaycastOptions::from(bag);
    bag.finish();
    return std::make_unique<RaycastFormFactors>(scene, mesh, options);
  }
  if (name == "hemicube") {
    HemicubeOptions options = HemicubeOptions::from(bag);
    bag.finish();
    return std::make_unique<HemicubeFormFactors>(scene, mesh, options);
  }
  if (name == "exact") {
    ExactOptions options = ExactOptions::from(bag);
    bag.finish();
    return std::make_unique<ExactFormFactors>(scene, mesh, options);
  }
  std::vector<std::string> names;
  for (const auto& m : form_factor_methods()) names.push_back(m.name);
  throw UsageError("unknown form-factor method '" + name +
                   "'; methods: " + text::join(names, ", "));
}

}  // namespace radlab
