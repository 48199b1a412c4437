// Procedural reconstructions of the test scenes of the papers radlab reproduces (docs/scenes.md,
// "Paper scenes"). The originals were never published, so these are rebuilt from the papers'
// descriptions and figures: the same kind of room, about the same number of patches and, at the
// documented mesh, about the same number of elements.
//
// - builtin:office         Cohen, Chen, Wallace & Greenberg 1988: two office cubicles, ~500
//                          patches; `--subdiv 4` gives ~7,000 elements.
// - builtin:room           Wu & Wang 2002, example B: a simple room; `--subdiv 2` gives 1,360
//                          (the paper's: 1,336).
// - builtin:computer-room  Wu & Wang 2002, example A: a closed computer room; `--subdiv 3`
//                          gives 4,860 (the paper's: 4,953).
//
// All three are closed (every ray leaving a front side hits a polygon), y is up, units are metres,
// every polygon is a planar convex quadrilateral ("patch") facing into the free space, materials
// are RGB, and each has a camera. Parameters: light_scale multiplies the emission, rho_scale the
// reflectances (the result must stay in [0, 1]).
#pragma once

#include "core/param_bag.h"
#include "scene/scene.h"

namespace radlab {

// The mesh each scene's element target refers to (documented in the table of built-ins).
inline constexpr int kOfficeSubdiv = 4;
inline constexpr int kRoomSubdiv = 2;
inline constexpr int kComputerRoomSubdiv = 3;

Scene make_office_scene(ParamBag& bag);
Scene make_room_scene(ParamBag& bag);
Scene make_computer_room_scene(ParamBag& bag);

}  // namespace radlab
