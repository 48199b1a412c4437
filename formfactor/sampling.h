// Stratified, jittered sample points on an element, uniform in area. Used for visibility rays.
#pragma once

#include <span>
#include <vector>

#include "core/random.h"
#include "scene/scene.h"

namespace radlab {

// `count` points: an m x m grid (m = ceil(sqrt(count))) of strata on the element's parameter
// square, `count` of its cells chosen without repetition, one jittered point in each. Points stay
// off the boundary by a relative `inset` so rays do not start on a neighbour's shared edge.
void stratified_points(std::span<const Vec3> corners, int count, Pcg32& rng, std::vector<Vec3>& out,
                       double inset = 1e-4);

}  // namespace radlab
