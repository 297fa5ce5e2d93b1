// Direct lobe integration over point cells, shared by accurate, bounded and auto.
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "kernels.hpp"
#include "points.hpp"

namespace arlight::lighting::detail {

// Smallest cosine the bounded method integrates for shininess s (derivation in direct.cpp).
double bounded_cos_threshold(double s);
// The same for method auto: a cut 1000x looser, within its error target (direct.cpp).
double auto_cos_threshold(double s);
// Smallest cosine whose c^s (> 1e-30) can still change a double-precision sum.
double exact_cos_threshold(double s);

// The smallest cone holding `dirs` (nearby directions: a block of texels or grid points): unit
// centre and angular radius (padded for rounding; pi when the directions cancel out).
struct Cone {
  glm::dvec3 centre;
  double radius;
};
Cone bounding_cone(std::span<const glm::dvec3> dirs);

// For each of the kQueries directions dirs[q]: acc[q * 4n + 4k + (0..3)] = (sum f L w, sum f w)
// for map k of `chain` (n maps) over at least the points whose cosine with dirs[q] exceeds
// min_cos[k] (non-decreasing in k); cells no direction reaches are skipped whole.
void integrate_direct(const PointCells& pts, const glm::dvec3* dirs, const PowerChain& chain,
                      std::span<const double> min_cos, double* acc);

// Integrates batches of directions that lie close together (a block of texels): the cells
// within reach of any of them are found once, then each group of kQueries directions sums
// those within its own reach. acc gets 4 x chain.size() values per direction.
class BatchIntegrator {
 public:
  BatchIntegrator(const PointCells& pts, const PowerChain& chain, double min_cos)
      : pts_(pts),
        chain_(chain),
        window_(std::acos(std::clamp(min_cos, -1.0, 1.0))),
        linear_(chain.size() == 1 && chain.exponent(0) == 1.0 && !pts.has_moments() &&
                pts.cell_sums.size() == 12 * pts.cells.size() && !pts.cells.empty()) {}
  void run(std::span<const glm::dvec3> dirs, double* acc);

 private:
  const PointCells& pts_;
  const PowerChain& chain_;
  double window_;                                    // lobe window radius (rad)
  // The clamped cosine lobe (s = 1, points without moments, pts.cell_sums made) is linear in
  // the direction wherever it is not clamped: a cell wholly above every horizon of a group
  // adds dot(dir, its cell_sums) exactly.
  bool linear_;
  PointCells gathered_;                              // the chain path's candidates, copied
  std::vector<const PointCells::Cell*> candidates_;  // the single-lobe path's, in place
  std::vector<double> lanes_;
};

}  // namespace arlight::lighting::detail
