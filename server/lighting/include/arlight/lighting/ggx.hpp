// The split sum's parts for glTF metallic-roughness shading (Karis 2013, "Real Shading in Unreal
// Engine 4"; Filament's libs/ibl): the GGX-prefiltered radiance chain and the DFG table.
//
// Roughness is glTF's perceptual roughness r, alpha = r^2. The prefiltered radiance for r at a
// direction R is the lobe-weighted mean the engines sample at run time, with n = v = R and
// h = norm(R + l):
//   sum L(l) D(h) (R.l)+ dw / sum D(h) (R.l)+ dw,   D = GGX (Trowbridge-Reitz).
// Like the thesis's maps (Alg. 4.1's normalisation) a constant environment gives that constant
// at every roughness; r = 1 (D constant) gives the cosine-weighted mean, the irradiance map.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "arlight/common/light_files.hpp"
#include "arlight/common/projection.hpp"
#include "arlight/lighting/lighting.hpp"

namespace arlight::lighting {

// Filament's level <-> roughness mapping and its one-line statement (common's: clients sample
// and write chains too).
using arlight::ggx_level_roughness;
using arlight::ggx_roughness_level;
using arlight::kGgxLevelMapping;

struct GgxChainSpec {
  int face = 256;      // level 0's face edge (a power of two)
  int min_face = 16;   // the last level's face edge; each level halves the face
  // The hierarchical sum's widest opening (see ggx.cpp): a group of input texels of angular
  // radius rho stands for its texels (by its moments) only where rho <= opening x its distance
  // from the lobe's axis (or x the lobe's width), and where the bound on that expansion's error
  // is within its share of the sum. Smaller is slower and closer to the exact sum.
  double opening = 0.5;
};

struct GgxLevel {
  int level = 0;
  double roughness = 0.0;
  EnvMap map;  // cube, face = spec.face >> level
  double seconds = 0.0;
};

struct GgxChain {
  std::vector<GgxLevel> levels;
  double total_seconds = 0.0;

  // The levels' maps and roughness, level 0 first (what the light files take).
  std::vector<EnvMap> maps() const {
    std::vector<EnvMap> m;
    for (const GgxLevel& l : levels) m.push_back(l.map);
    return m;
  }
  std::vector<double> roughness() const {
    std::vector<double> r;
    for (const GgxLevel& l : levels) r.push_back(l.roughness);
    return r;
  }
};

// The chain of `input` (any projection; values finite and >= 0), on all cores. Level 0 is the
// input resampled to the cube (the mirror), level k the prefilter at ggx_level_roughness(k, n).
// Throws InputError for a face that is not a power of two or a min_face above it; Cancelled
// when hooks.stop is requested (hooks.on_tile reports tiles with map = the level).
GgxChain compute_ggx_chain(const EnvMap& input, const GgxChainSpec& spec = {},
                           const Hooks& hooks = {});

// A GGX chain that follows a changing environment, as MapUpdater does for the Phong set (issue
// 34 §2): each update finds the input texels that changed (in cones, with the power of their
// change) and recomputes only the output tiles of each level those changes can move by more
// than `tolerance` of the tile's smallest value, bounded by the lobe's peak value over the
// cone's nearest approach. What a tile skips adds up (its debt) until it is recomputed, so many
// small changes do not drift past the tolerance either. Level 0 (the mirror) is made afresh.
// The first update, and one with another input layout, computes everything.
class GgxUpdater {
 public:
  explicit GgxUpdater(GgxChainSpec spec = {}, double tolerance = 0.02);
  ~GgxUpdater();
  GgxUpdater(GgxUpdater&&) noexcept;
  GgxUpdater& operator=(GgxUpdater&&) noexcept;

  // Throws as compute_ggx_chain does; `measured` as MapUpdater::update takes it. After a throw
  // (Cancelled too) the next update judges against the last chain that completed.
  const GgxChain& update(const EnvMap& input, const Hooks& hooks = {},
                         std::span<const float> measured = {});
  // Of the last update: the share of each level's tiles recomputed, and of the input's texels
  // that counted as changed.
  std::span<const double> recomputed() const;
  double changed() const;
  const GgxChainSpec& spec() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The prefilter for each roughness (> 0) in any output layout, by the hierarchical sum over
// one pyramid of the input (hooks.on_tile reports tiles with map = the index in `roughness`).
std::vector<EnvMap> ggx_prefilter(const EnvMap& input, std::span<const double> roughness,
                                  const EnvLayout& output, double opening = GgxChainSpec{}.opening,
                                  const Hooks& hooks = {});
EnvMap ggx_prefilter(const EnvMap& input, double roughness, const EnvLayout& output,
                     double opening = GgxChainSpec{}.opening, const Hooks& hooks = {});

// The exact prefilter at each direction (unit) of `dirs`: the sum above over every input texel
// at its centre, in double. The reference the tests and benchmarks measure against; all cores.
std::vector<glm::dvec3> ggx_prefilter_exact(const EnvMap& input, double roughness,
                                            std::span<const glm::dvec3> dirs);

// The split sum's DFG table is common's (arlight/common/brdf.hpp): the client shades with it.

}  // namespace arlight::lighting
