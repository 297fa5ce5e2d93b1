// The inner loops of direct lobe integration (thesis Alg. 4.1 lines 14-33): for one output
// direction d and one cell of points, accumulate sum f L w and sum f w with f = max(0, d.w)^s.
#pragma once

#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "points.hpp"

namespace arlight::lighting::detail {

// Raises cosines to every exponent of an ascending shininess list with as few operations as
// possible: s = 1 is a copy, s_k = r * s_(k-1) with integer r is r-th power of the previous
// map's values by repeated squaring (1, 10, 20, 40, 80, 160, 320, 1280 costs 11 multiplies),
// other integers are integer powers of the cosine, anything else exp(s log c).
class PowerChain {
 public:
  explicit PowerChain(std::span<const double> ascending);
  int size() const { return int(steps_.size()); }
  double exponent(int k) const { return steps_[std::size_t(k)].s; }

  struct Step {
    enum Kind { Copy, PowPrev, PowCos, ExpLog } kind;
    int r;     // integer exponent of PowPrev / PowCos
    double s;  // the shininess
  };
  const std::vector<Step>& steps() const { return steps_; }

 private:
  std::vector<Step> steps_;
};

// Directions integrated together by accumulate_chain.
constexpr int kQueries = 4;
// Doubles per accumulator in accumulate_chain's lanes.
constexpr int kLaneWidth = 8;

// For each of the kQueries directions dirs[q] and maps k < maps:
//   lanes[q * stride + (4k + c) * kLaneWidth + j] += the lane-j part of sum f_k L_c w (c = 0..2)
//   and of sum f_k w (c = 3) over points [begin, end) (multiples of kCellAlign),
// with stride = 4 * kLaneWidth * chain.size(). Summing the lanes gives the totals. Double
// precision throughout.
void accumulate_chain(const PointCells& pts, std::uint32_t begin, std::uint32_t end,
                      const glm::dvec3* dirs, const PowerChain& chain, int maps, double* lanes);

// One shininess (chain of one step) in single precision, for the auto method's windows where
// float's 1e-7 is far below the error target and twice the lanes halve the time:
// acc[4q + c] += sum f L_c w (c < 3), sum f w (c = 3) for each direction dirs[q]. Needs
// pts.make_float_copy(); partial sums are added in double after every run of points.
void accumulate_single_f32(const PointCells& pts, std::uint32_t begin, std::uint32_t end,
                           const glm::dvec3* dirs, const PowerChain& chain, double* acc);

// Sums the lanes of one direction's accumulators: acc[i] for i < 4 * maps.
void reduce_lanes(const double* lanes, int maps, double* acc);

// Flushes denormals to zero on this thread while alive: high powers of cosines underflow
// through the denormal range, where x86 arithmetic is ~100x slower, and contribute nothing.
class FlushDenormals {
 public:
  FlushDenormals();
  ~FlushDenormals();
  FlushDenormals(const FlushDenormals&) = delete;
  FlushDenormals& operator=(const FlushDenormals&) = delete;

 private:
  unsigned saved_;
};

}  // namespace arlight::lighting::detail
