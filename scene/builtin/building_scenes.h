// The scaling family: `builtin:floors:k=N`, a building of N identical office storeys stacked
// around an open atrium, so that the storeys see one another and the polygon count grows
// linearly in N (issue 33, item 2: links, memory and time against polygons for hierarchical
// radiosity with and without clustering).
//
// Geometry (metres, y up): a 12 x 12 m footprint, storeys 3.5 m apart (3 m of room under a 0.5 m
// slab), a 4 x 4 m atrium through every slab at the centre (x, z in [4, 8]). Per storey: the
// floor (solid on the ground storey, around the atrium above it), the ceiling (around the atrium
// below the roof, solid at the roof), four outer walls, the four faces of the slab's edge around
// the atrium (not under the roof), eight desks (solid 2 x 1 x 0.5 m blocks at 0.5 m, all six
// faces; their legs are left out so nothing rests on the floor) and eight 1 x 1 m luminaires set
// into the ceiling, one over each desk (the ceiling patches lying half in a lamp's square or
// holding its centre: exactly the square at the default patch, a patch or two at coarse ones).
// Every surface is split into patches of about `patch` metres (at least one along each edge), as
// the paper scenes are. At the default patch 0.5 every coordinate is a multiple of 0.5 m, so areas
// are exact in double: N storeys have 1,856 N + 96 polygons and 464 N + 24 m^2 (a middle storey's
// 1,856 and 464; the ground's solid floor and the roof add 64 + 64 and 16 + 16, the roof's missing
// slab edge takes 32 and 8), and N = 108 passes 200,000 polygons.
//
// The building is closed: every ray leaving a front side into the free space meets a front side
// (tested). Materials are RGB (walls, ceiling, floor, slab edge, desk, luminaire); light_scale
// multiplies the luminaires' emission.
#pragma once

#include "core/param_bag.h"
#include "scene/scene.h"

namespace radlab {

Scene make_floors_scene(ParamBag& bag);

}  // namespace radlab
