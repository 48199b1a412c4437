// Scenes built into radlab, made procedurally from parameters: `builtin:NAME:key=value,...`.
// `radlab scenes` lists them with their parameters; docs/scenes.md describes each.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "scene/scene.h"

namespace radlab {

struct BuiltinParameter {
  std::string name;
  std::string default_value;
  std::string help;
};

struct BuiltinScene {
  std::string name;
  std::string summary;
  std::vector<BuiltinParameter> parameters;
  std::function<Scene(ParamBag&)> make;  // reads its parameters from the bag
};

// The explicit table of built-in scenes.
const std::vector<BuiltinScene>& builtin_scenes();

// Builds `builtin:NAME[:k=v,...]` (the part after "builtin:"). Unknown names or keys are
// UsageErrors listing the valid ones.
Scene make_builtin_scene(const std::string& name_and_parameters);

}  // namespace radlab
