// Shadow-casting light sources from an environment map (tutorial §6): the source set is the
// brightest texels that hold `power_share` (the tutorial's ~70 %) of the light a receiver plane
// gets from the whole map (and any as bright as the last one taken); it is clustered top-down into
// a binary KD-tree (§6.2: "subdivision of a binary KD-tree node only increases the number of leaves
// by one"), each split on the directions' widest axis at the power median (Debevec 2005's median
// cut), so a renderer can pick any number of clusters at run time and still account for the whole
// set (§6.4). The rest of the light (1 - power_share) is left to the ambient transfer.
#pragma once

#include <glm/vec3.hpp>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/common/sh.hpp"

namespace arlight {

struct LightCluster {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, towards the light: its texels' centroid
  glm::vec3 irradiance{0.0f};  // what it gives the receiver plane: sum L w max(0, n.d) (RGB)
  float solid_angle = 0.0f;    // steradians
  float spread = 0.0f;         // radians: the texels' irradiance-weighted mean angle from direction
  int texels = 0;
  int first_child = -1;  // its halves are nodes first_child and first_child + 1; -1: a leaf
};

struct LightTree {
  glm::vec3 normal{0.0f, 1.0f, 0.0f};   // the receiver plane's (unit, world frame)
  glm::vec3 receiver_irradiance{0.0f};  // what the whole map gives the plane (RGB)
  std::vector<LightCluster> nodes;      // nodes[0]: the whole source set; empty: a black sky
  int leaves() const;
};

struct LightTreeOptions {
  double power_share = 0.7;  // of the plane's irradiance (luminance), tutorial §6
  int max_leaves = 32;       // the clusters the tree ends in (fewer when the set has fewer texels)
};

// Throws std::invalid_argument for a normal of zero length or options out of range
// (power_share in (0, 1], max_leaves >= 1).
LightTree build_light_tree(const EnvMap& map, glm::dvec3 normal,
                           const LightTreeOptions& options = {});

// Tutorial §6.4's run-time choice: from the root, repeatedly split the chosen cluster that gives
// the receiver the most light (luminance), until there are n or only leaves are left. Indices
// into tree.nodes, brightest first; together they hold the whole source set.
std::vector<int> select_lights(const LightTree& tree, int n);

// The room's primary light, for engines that take one directional light beside the ambient
// (light.json's primary_light; WebXR's primaryLightDirection / Intensity): the brightest of the
// light tree's first kPrimaryClusters clusters with those within kPrimaryMergeRadians of it (the
// median cut splits a bright lamp itself), the tree built for a receiver facing the SH's
// dominant direction (so a light anywhere on the sphere can be it). `direction`: their
// luminance-weighted mean (unit, towards the light); `colour`: their illuminance at normal
// incidence (RGB: each cluster's irradiance on that receiver over the cosine there). A channel
// more than 16x both others in a texel (lossy compression's ringing) is limited to that first.
// A black room: colour 0, +Y.
inline constexpr int kPrimaryClusters = 8;
inline constexpr double kPrimaryMergeRadians = 0.35;  // 20 degrees
DominantLight primary_light(const EnvMap& map, const ShCoeffs& sh);

}  // namespace arlight
