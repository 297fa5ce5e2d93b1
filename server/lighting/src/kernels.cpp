// Compiled with -ffast-math -fopenmp-simd (see CMakeLists.txt) so that the reductions vectorize
// and exp/log map to glibc's vector math library. Inputs are sanitized (finite, >= 0) and every
// cosine fed to log() is > 0, so the fast-math assumptions hold.
#include "kernels.hpp"

#include <xmmintrin.h>

#include <cmath>
#include <stdexcept>

#if defined(__clang__)
// clang refuses a 64-byte vector passed between a target clone and a helper built for another
// target (GCC only warns, -Wpsabi): the clang builds (sanitizers, fuzzing) keep one version.
#define ARLIGHT_SIMD_CLONES
#else
#define ARLIGHT_SIMD_CLONES __attribute__((target_clones("avx512f", "fma", "default")))
#endif

namespace arlight::lighting::detail {

PowerChain::PowerChain(std::span<const double> ascending) {
  for (std::size_t k = 0; k < ascending.size(); ++k) {
    const double s = ascending[k];
    if (s < 1.0) throw std::invalid_argument("shininess must be >= 1");
    if (k > 0 && s < ascending[k - 1]) throw std::invalid_argument("shininess not ascending");
    if (s == 1.0) {
      steps_.push_back({Step::Copy, 1, s});
      continue;
    }
    if (k > 0) {
      const double ratio = s / ascending[k - 1];
      if (ratio == std::floor(ratio) && ratio <= 64.0) {
        steps_.push_back({Step::PowPrev, int(ratio), s});
        continue;
      }
    }
    if (s == std::floor(s) && s <= 65536.0)
      steps_.push_back({Step::PowCos, int(s), s});
    else
      steps_.push_back({Step::ExpLog, 0, s});
  }
}

namespace {

constexpr int kW = kLaneWidth;

// Eight doubles: one AVX-512 register in the avx512f clone, two or four narrower ones in the
// others. Loads and stores go through memcpy, so no alignment is assumed.
typedef double V __attribute__((vector_size(8 * sizeof(double))));
static_assert(kW == 8 && kCellAlign % kW == 0);

inline V load(const double* p) {
  V v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void store(double* p, V v) { __builtin_memcpy(p, &v, sizeof v); }

// out[g] = base[g]^e (e >= 1) for every group by left-to-right binary exponentiation. The bit
// loop is outside so the groups' multiplications are independent (throughput, not latency).
inline void int_pow(const V* base, V* out, int groups, int e) {
  int top = 0;
  while ((e >> (top + 1)) != 0) ++top;
  for (int g = 0; g < groups; ++g) out[g] = base[g];
  for (int bit = top - 1; bit >= 0; --bit) {
    if ((e >> bit) & 1)
      for (int g = 0; g < groups; ++g) out[g] = out[g] * out[g] * base[g];
    else
      for (int g = 0; g < groups; ++g) out[g] = out[g] * out[g];
  }
}

inline V exp_log_pow(V c, double s) {
  alignas(64) double t[kW];
  store(t, c);
#pragma omp simd
  for (int j = 0; j < kW; ++j)
    t[j] = t[j] > 0.0 ? std::exp(s * std::log(t[j] > 0.0 ? t[j] : 1.0)) : 0.0;
  return load(t);
}

}  // namespace

// Per run of up to kMaxCellPoints points: the cosines of every group of 8 points for each of
// the kQueries directions, then map by map the powers (from the cosines or the previous map's
// powers, kept in small buffers) and their weighted sums in registers, added to the per-lane
// accumulators once per run. The directions share every load of the points' radiance and
// weight, which is what bounds a single direction's loop.
ARLIGHT_SIMD_CLONES
void accumulate_chain(const PointCells& pts, std::uint32_t begin, std::uint32_t end,
                      const glm::dvec3* dirs, const PowerChain& chain, int maps, double* lanes) {
  constexpr int kGroups = int(kMaxCellPoints) / kW;
  constexpr int Q = kQueries;
  const std::size_t stride = 4 * std::size_t(kW) * std::size_t(chain.size());
  const V zero = {0, 0, 0, 0, 0, 0, 0, 0};
  const auto& steps = chain.steps();
  const bool moments = pts.has_moments();
  for (; begin < end; begin += kMaxCellPoints) {
    const std::uint32_t run_end = std::min(end, begin + kMaxCellPoints);
    const int groups = int(run_end - begin) / kW;
    V cosine[Q][kGroups], power[2][Q][kGroups];
    for (int q = 0; q < Q; ++q) {
      const V dx = zero + dirs[q].x, dy = zero + dirs[q].y, dz = zero + dirs[q].z;
      for (int g = 0; g < groups; ++g) {
        const std::size_t i = begin + std::size_t(g) * kW;
        const V c =
            dx * load(pts.x.data() + i) + dy * load(pts.y.data() + i) + dz * load(pts.z.data() + i);
        cosine[q][g] = c > zero ? c : zero;
      }
    }
    for (int k = 0; k < maps; ++k) {
      const PowerChain::Step& step = steps[std::size_t(k)];
      V(*cur)[kGroups] = power[k & 1];
      V(*prev)[kGroups] = k == 0 ? cosine : power[(k - 1) & 1];
      if (k > 0 && steps[std::size_t(k - 1)].kind == PowerChain::Step::Copy) prev = cosine;
      V acc[Q][4];
      for (int q = 0; q < Q; ++q) acc[q][0] = acc[q][1] = acc[q][2] = acc[q][3] = zero;
      // The weighted sums, with f from `power_of(q, g)`, which also stores it for the next map.
      // Prefiltered points add the first-order term of the lobe over their cell: the gradient
      // of (d.w)^s is s c^(s-1) d, applied to the radiance's first moment M_c (points.hpp).
      const double s_k = step.s;
      auto accumulate = [&](auto&& power_of) {
        for (int g = 0; g < groups; ++g) {
          const std::size_t i = begin + std::size_t(g) * kW;
          const V lr = load(pts.lr.data() + i), lg = load(pts.lg.data() + i);
          const V lb = load(pts.lb.data() + i), w = load(pts.w.data() + i);
          if (!moments) {
            for (int q = 0; q < Q; ++q) {
              const V f = power_of(q, g);
              acc[q][0] += f * lr;
              acc[q][1] += f * lg;
              acc[q][2] += f * lb;
              acc[q][3] += f * w;
            }
            continue;
          }
          V m[9];
          for (int a = 0; a < 9; ++a) m[a] = load(pts.moment[a].data() + i);
          for (int q = 0; q < Q; ++q) {
            const V f = power_of(q, g);
            const V c = cosine[q][g];
            const V slope = c > zero ? s_k * f / (c > zero ? c : zero + 1.0) : zero;
            const glm::dvec3 d = dirs[q];
            acc[q][0] += f * lr + slope * (d.x * m[0] + d.y * m[1] + d.z * m[2]);
            acc[q][1] += f * lg + slope * (d.x * m[3] + d.y * m[4] + d.z * m[5]);
            acc[q][2] += f * lb + slope * (d.x * m[6] + d.y * m[7] + d.z * m[8]);
            acc[q][3] += f * w;
          }
        }
      };
      if (step.kind == PowerChain::Step::Copy) {
        cur = cosine;
        accumulate([&](int q, int g) { return cosine[q][g]; });
      } else if (step.kind == PowerChain::Step::PowPrev && step.r == 2) {
        accumulate([&](int q, int g) { return cur[q][g] = prev[q][g] * prev[q][g]; });
      } else if (step.kind == PowerChain::Step::PowPrev && step.r == 4) {
        accumulate([&](int q, int g) {
          const V p2 = prev[q][g] * prev[q][g];
          return cur[q][g] = p2 * p2;
        });
      } else {
        // Longer chains as separate passes, then the sums.
        for (int q = 0; q < Q; ++q) {
          if (step.kind == PowerChain::Step::PowPrev)
            int_pow(prev[q], cur[q], groups, step.r);
          else if (step.kind == PowerChain::Step::PowCos)
            int_pow(cosine[q], cur[q], groups, step.r);
          else
            for (int g = 0; g < groups; ++g) cur[q][g] = exp_log_pow(cosine[q][g], step.s);
        }
        accumulate([&](int q, int g) { return cur[q][g]; });
      }
      for (int q = 0; q < Q; ++q) {
        double* a = lanes + q * stride + 4 * std::size_t(kW) * std::size_t(k);
        for (int c = 0; c < 4; ++c) store(a + c * kW, load(a + c * kW) + acc[q][c]);
      }
    }
  }
}

namespace {

constexpr int kWf = 16;
// Sixteen floats: one AVX-512 register in the avx512f clone.
typedef float F __attribute__((vector_size(kWf * sizeof(float))));
static_assert(kCellAlign % kWf == 0);

inline F loadf(const float* p) {
  F v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

// Sum of the lanes, pairwise in float (16 terms that each hold at most a run's share).
inline double hsum(F v) {
  typedef float H __attribute__((vector_size(kWf / 2 * sizeof(float))));
  typedef float Q4 __attribute__((vector_size(kWf / 4 * sizeof(float))));
  const H h = __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7) +
              __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
  const Q4 q =
      __builtin_shufflevector(h, h, 0, 1, 2, 3) + __builtin_shufflevector(h, h, 4, 5, 6, 7);
  return double(q[0] + q[2]) + double(q[1] + q[3]);
}

// Points summed in float before the partial sums go to double.
constexpr std::uint32_t kFloatRun = 1024;

}  // namespace

ARLIGHT_SIMD_CLONES
void accumulate_single_f32(const PointCells& pts, std::uint32_t begin, std::uint32_t end,
                           const glm::dvec3* dirs, const PowerChain& chain, double* acc) {
  constexpr int Q = kQueries;
  const PowerChain::Step& step = chain.steps()[0];
  const bool moments = pts.has_moments();
  const F zero = {}, one = zero + 1.0f;
  const float s_f = float(step.s);
  const bool integer =
      step.kind == PowerChain::Step::PowCos || step.kind == PowerChain::Step::PowPrev;
  // cos^r by square-and-multiply from the top bit down (r = 1280: 10 squarings, 1 multiply).
  const int e = integer ? step.r : 1;
  int top = 0;
  while ((e >> (top + 1)) != 0) ++top;
  F dx[Q], dy[Q], dz[Q];
  for (int q = 0; q < Q; ++q)
    dx[q] = zero + float(dirs[q].x), dy[q] = zero + float(dirs[q].y),
    dz[q] = zero + float(dirs[q].z);
  for (; begin < end; begin += kFloatRun) {
    const std::uint32_t run_end = std::min(end, begin + kFloatRun);
    F sum[Q][4];
    for (int q = 0; q < Q; ++q) sum[q][0] = sum[q][1] = sum[q][2] = sum[q][3] = zero;
    // Two groups of kWf points at a time, everything for the kQueries directions in registers:
    // the 2 x kQueries power chains are independent, so their multiplies overlap. An odd last
    // group is paired with itself and its twin's terms are multiplied by 0.
    for (std::uint32_t i = begin; i < run_end; i += 2 * kWf) {
      const bool pair = i + kWf < run_end;
      const std::uint32_t at[2] = {i, pair ? i + kWf : i};
      F c[2][Q], f[2][Q];
      for (int h = 0; h < 2; ++h) {
        const F x = loadf(pts.fx.data() + at[h]), y = loadf(pts.fy.data() + at[h]),
                z = loadf(pts.fz.data() + at[h]);
        for (int q = 0; q < Q; ++q) {
          const F d = dx[q] * x + dy[q] * y + dz[q] * z;
          c[h][q] = d > zero ? d : zero;
          f[h][q] = c[h][q];
        }
      }
      if (integer) {
        for (int bit = top - 1; bit >= 0; --bit) {
          for (int h = 0; h < 2; ++h)
            for (int q = 0; q < Q; ++q) f[h][q] = f[h][q] * f[h][q];
          if ((e >> bit) & 1)
            for (int h = 0; h < 2; ++h)
              for (int q = 0; q < Q; ++q) f[h][q] = f[h][q] * c[h][q];
        }
      } else if (step.kind == PowerChain::Step::ExpLog) {
        for (int h = 0; h < 2; ++h)
          for (int q = 0; q < Q; ++q) {
            alignas(64) float t[kWf];
            __builtin_memcpy(t, &f[h][q], sizeof t);
#pragma omp simd
            for (int j = 0; j < kWf; ++j)
              t[j] = t[j] > 0.0f ? std::exp(s_f * std::log(t[j] > 0.0f ? t[j] : 1.0f)) : 0.0f;
            f[h][q] = loadf(t);
          }
      }
      if (!pair)
        for (int q = 0; q < Q; ++q) f[1][q] = zero;
      for (int h = 0; h < 2; ++h) {
        const std::uint32_t j = at[h];
        const F lr = loadf(pts.flr.data() + j), lg = loadf(pts.flg.data() + j);
        const F lb = loadf(pts.flb.data() + j), w = loadf(pts.fw.data() + j);
        if (!moments) {
          for (int q = 0; q < Q; ++q) {
            sum[q][0] += f[h][q] * lr;
            sum[q][1] += f[h][q] * lg;
            sum[q][2] += f[h][q] * lb;
            sum[q][3] += f[h][q] * w;
          }
          continue;
        }
        // The moments' first-order term: the lobe's slope s c^(s-1) = s f / c along them.
        F m[9];
        for (int a = 0; a < 9; ++a) m[a] = loadf(pts.fmoment[a].data() + j);
        for (int q = 0; q < Q; ++q) {
          const F cq = c[h][q], fq = f[h][q];
          const F slope = cq > zero ? s_f * fq / (cq > zero ? cq : one) : zero;
          sum[q][0] += fq * lr + slope * (dx[q] * m[0] + dy[q] * m[1] + dz[q] * m[2]);
          sum[q][1] += fq * lg + slope * (dx[q] * m[3] + dy[q] * m[4] + dz[q] * m[5]);
          sum[q][2] += fq * lb + slope * (dx[q] * m[6] + dy[q] * m[7] + dz[q] * m[8]);
          sum[q][3] += fq * w;
        }
      }
    }
    for (int q = 0; q < Q; ++q)
      for (int c = 0; c < 4; ++c) acc[4 * q + c] += hsum(sum[q][c]);
  }
}

void reduce_lanes(const double* lanes, int maps, double* acc) {
  for (int i = 0; i < 4 * maps; ++i) {
    double sum = 0.0;
    for (int j = 0; j < kW; ++j) sum += lanes[i * kW + j];
    acc[i] = sum;
  }
}

FlushDenormals::FlushDenormals() : saved_(_mm_getcsr()) {
  _mm_setcsr(saved_ | 0x8040u);  // FTZ | DAZ
}
FlushDenormals::~FlushDenormals() { _mm_setcsr(saved_); }

}  // namespace arlight::lighting::detail
