// Stiff and extreme scenes for the stability table (docs/stability.md; docs/scenes.md,
// "Stability scenes"). Each is a small closed or open box arrangement with one thing pushed to an
// extreme, so that a solver, the form factors or the certified reference meet it head on:
//
// - builtin:tiny-light   a 4 x 3 x 5 m closed room lit by one tiny, very bright square (1 mm,
//                        Ke 1e6) hanging just below the ceiling: hemicubes of the room miss it.
// - builtin:area-ratio   the closed unit cube whose floor has a small corner piece: neighbouring
//                        polygons whose areas differ by `ratio` (1e6).
// - builtin:slivers      the closed unit cube whose floor is a fan of sliver triangles of aspect
//                        `aspect` (1e-4) plus one quadrilateral for the rest.
// - builtin:overlap      the closed unit cube with a second, coplanar polygon lying on its floor
//                        (a "rug"): unphysical input, row sums of F above 1.
// - builtin:near-pair    two parallel unit squares facing each other `gap` (1e-3 m) apart, open
//                        at the sides: a near-singular pair for the quadrature.
//
// The closed box at high reflectance, no emitter and nothing reflective are builtin:cube with
// rho / emission parameters. All are grey (one channel); all parameters are checked (UsageError).
#pragma once

#include "core/param_bag.h"
#include "scene/scene.h"

namespace radlab {

Scene make_tiny_light_scene(ParamBag& bag);
Scene make_area_ratio_scene(ParamBag& bag);
Scene make_slivers_scene(ParamBag& bag);
Scene make_overlap_scene(ParamBag& bag);
Scene make_near_pair_scene(ParamBag& bag);

}  // namespace radlab
