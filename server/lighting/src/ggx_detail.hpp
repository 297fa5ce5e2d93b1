// What the GGX chain's computation (ggx.cpp) shares with GgxUpdater (ggx_updater.cpp).
#pragma once

#include <vector>

#include "arlight/lighting/ggx.hpp"
#include "job.hpp"

namespace arlight::lighting::detail {

// The output tiles the prefilter computes (and GgxUpdater judges) one at a time.
OutputTexels ggx_tiles(const EnvLayout& output);
// A cone around a tile's texels: their mean direction, and the widest angle from it to one of
// them (plus a 1e-6 pad). An empty tile: +Z, 0.
struct TileCone {
  glm::dvec3 centre{0.0, 0.0, 1.0};
  double tau = 0.0;
};
TileCone tile_cone(const TileTexels& texels);
// The number of levels of spec's chain; throws InputError for a face or min_face that is not a
// power of two, or a min_face above the face.
int ggx_chain_levels(const GgxChainSpec& spec);
// The prefilter's weight D(h) (R.l)+ at R.l = cos_angle, up to the constant the sums share, and
// its integral over the sphere (the sums' denominator for a uniform input).
double ggx_lobe_value(double roughness, double cos_angle);
double ggx_lobe_integral(double roughness);
// compute_ggx_chain(); with `redo` (per level, one flag per ggx_tiles() tile; level 0 is always
// made afresh) only the flagged tiles of levels >= 1, the rest copied from `previous`.
GgxChain ggx_chain(const EnvMap& input, const GgxChainSpec& spec, const Hooks& hooks,
                   const GgxChain* previous, const std::vector<std::vector<char>>* redo);

}  // namespace arlight::lighting::detail
