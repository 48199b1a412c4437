// `radlab reference SCENE --out B.csv`: the certified reference solution and its bound.
#include <cstdio>

#include "cli/cli_common.h"
#include "core/log.h"
#include "core/output_file.h"
#include "experiments/run/outputs.h"

namespace radlab::cli {

void add_reference_command(CLI::App& app) {
  auto* command = app.add_subcommand("reference", "solve the system to a certified high precision");
  auto scene = std::make_shared<SceneOptions>();
  auto ff = std::make_shared<FormFactorOptions>();
  auto out = std::make_shared<std::string>();
  add_scene_options(*command, *scene);
  add_form_factor_options(*command, *ff, false);
  command->add_option("--out", *out, "CSV element,area,B_r,B_g,B_b");
  command->callback([scene, ff, out]() {
    if (!out->empty()) check_writable(*out);  // before the computation, not after it
    auto problem = prepare_problem(make_problem_spec(*scene, *ff));
    const Reference& r = *problem->reference;
    std::printf("reference    %s\n", r.summary().c_str());
    std::printf("bound        ||B - B*||_inf <= %.6g  (%.3g of max B)\n", r.bound_inf,
                r.bound_relative);
    std::printf("certified    for %s\n", r.system.c_str());
    if (!out->empty()) {
      ensure_parent_folder(*out);
      write_radiosity_csv(*out, problem->mesh, r.B);
      log::info("wrote " + *out);
    }
  });
}

}  // namespace radlab::cli
