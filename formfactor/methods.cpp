// The explicit table of form-factor methods and the factory.
#include "core/error.h"
#include "core/text.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/raycast.h"

namespace radlab {

const std::vector<FormFactorMethodInfo>& form_factor_methods() {
  static const std::vector<FormFactorMethodInfo> table = {
      {"raycast",
       "Lambert point-to-polygon formula integrated over i, times an Embree visibility fraction",
       {{"tolerance", "1e-4: relative quadrature error per pair"},
        {"rays", "16: visibility rays per pair that can be occluded"},
        {"seed", "0: seed of the jittered visibility samples"},
        {"max_order", "8: largest fixed Gauss rule per axis before adaptive subdivision"}}},
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
  std::vector<std::string> names;
  for (const auto& m : form_factor_methods()) names.push_back(m.name);
  throw UsageError("unknown form-factor method '" + name + "'; methods: " + text::join(names, ", "));
}

}  // namespace radlab
