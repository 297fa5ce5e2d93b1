// Real SH from normalized recurrences (no factorials, unlike thesis Alg. 2.5/2.6, whose
// factorials overflow at order 86 and lose accuracy beyond order ~35, §6.2.1).
//
// With z = cos(theta) and (x + iy)^m = sin^m(theta) e^{i m phi}:
//   Y_l^0 = Q_l^0(z),  Y_l^m = sqrt(2) Q_l^m(z) Re (x+iy)^m,  Y_l^-m = sqrt(2) Q_l^m(z) Im (x+iy)^m
// where Q_l^m = P~_l^m / sin^m(theta) is a polynomial in z obeying the standard stable
// recurrence of fully normalized Legendre functions:
//   Q_m^m   = sqrt(1/(4 pi)) * prod_{k=1..m} sqrt((2k+1)/(2k))
//   Q_l^m   = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),
//   a_lm    = sqrt((4l^2 - 1) / (l^2 - m^2)),  b_lm = sqrt(((l-1)^2 - m^2) / (4(l-1)^2 - 1)).
// Working in Cartesian form needs no trigonometry per direction and no division by sin(theta),
// so the poles are exact; (x+iy)^m underflows gracefully to 0 where the true value is below
// the double range anyway.
#include "arlight/common/sh.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>

#include "parallel.hpp"

// Multi-versioned SIMD kernels: one binary runs everywhere and uses AVX-512 or AVX+FMA where the
// CPU has them (GCC function multiversioning). ISA names rather than arch= keep the clones'
// arch equal to the default one, so GCC may inline the (default-target) lambdas and helpers
// into each clone; `flatten` makes it do so.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define ARLIGHT_SIMD_CLONES __attribute__((target_clones("avx512f", "fma", "default"), flatten))
#else
#define ARLIGHT_SIMD_CLONES
#endif

namespace arlight {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kMaxOrder = 4096;

void check_order(int order) {
  if (order < 1 || order > kMaxOrder)
    throw std::invalid_argument("SH order must be in [1, " + std::to_string(kMaxOrder) + "], got " +
                                std::to_string(order));
}

// Recurrence constants for one order: for each m, Q_m^m and then (a_lm, a_lm * b_lm) for
// l = m+1 .. order-1, packed column after column.
struct ShTables {
  int order = 0;
  std::vector<double> qmm;
  std::vector<double> a, ab;
  std::vector<std::size_t> column;  // start of column m in a / ab

  explicit ShTables(int n) : order(n), qmm(n), column(n + 1) {
    double q = std::sqrt(1.0 / (4.0 * kPi));
    for (int m = 0; m < n; ++m) {
      if (m > 0) q *= std::sqrt((2.0 * m + 1.0) / (2.0 * m));
      qmm[m] = q;
      column[m] = a.size();
      for (int l = m + 1; l < n; ++l) {
        const double l2 = double(l) * l, m2 = double(m) * m, lm1 = l - 1.0;
        const double alm = std::sqrt((4.0 * l2 - 1.0) / (l2 - m2));
        const double blm = std::sqrt((lm1 * lm1 - m2) / (4.0 * lm1 * lm1 - 1.0));
        a.push_back(alm);
        ab.push_back(alm * blm);
      }
    }
    column[n] = a.size();
  }
};

std::shared_ptr<const ShTables> tables_for(int order) {
  check_order(order);
  static std::mutex mutex;
  static std::map<int, std::shared_ptr<const ShTables>> cache;
  std::lock_guard lock(mutex);
  auto& slot = cache[order];
  if (!slot) slot = std::make_shared<const ShTables>(order);
  return slot;
}

glm::dvec3 unit(glm::dvec3 d) {
  const double n = glm::length(d);
  if (!(n > 0.0) || !std::isfinite(n))
    throw std::invalid_argument("SH direction must be a finite non-zero vector");
  return d / n;
}

// ---- batched kernels ----------------------------------------------------------------------

constexpr int kLanes = 64;  // directions processed together; the arrays stay in L1
constexpr int kWidth = 8;   // doubles in the widest SIMD register (AVX-512)

struct alignas(64) Batch {
  double x[kLanes], y[kLanes], z[kLanes];
  double v[3][kLanes];  // projection: weighted radiance; reconstruction: output
  int count = 0;
};

// Walks every (l, m >= 0) for a batch, handing on_l the column of Q_l^m values. on_m(m, re, im)
// is called first for each m with Re/Im (x+iy)^m.
template <class OnM, class OnL>
inline __attribute__((always_inline)) void for_each_lm(const ShTables& t, const Batch& b,
                                                       OnM&& on_m, OnL&& on_l) {
  alignas(64) double re[kLanes], im[kLanes], q0[kLanes], q1[kLanes];
  for (int i = 0; i < kLanes; ++i) re[i] = 1.0, im[i] = 0.0;
  for (int m = 0; m < t.order; ++m) {
    if (m > 0) {
#pragma omp simd
      for (int i = 0; i < kLanes; ++i) {
        const double r = re[i] * b.x[i] - im[i] * b.y[i];
        im[i] = re[i] * b.y[i] + im[i] * b.x[i];
        re[i] = r;
      }
    }
    on_m(m, re, im);
    const double qmm = t.qmm[m];
    for (int i = 0; i < kLanes; ++i) q1[i] = qmm, q0[i] = 0.0;
    on_l(m, m, q1);
    double* prev = q1;  // Q_{l-1}
    double* cur = q0;   // Q_{l-2}, overwritten with Q_l
    const double* a = t.a.data() + t.column[m];
    const double* ab = t.ab.data() + t.column[m];
    for (int l = m + 1; l < t.order; ++l) {
      const double al = a[l - m - 1], abl = ab[l - m - 1];
#pragma omp simd
      for (int i = 0; i < kLanes; ++i) cur[i] = al * b.z[i] * prev[i] - abl * cur[i];
      on_l(l, m, cur);
      std::swap(prev, cur);
    }
  }
}

// acc[3 * index + c] += sum over the batch of Y_lm(dir) * v[c]
ARLIGHT_SIMD_CLONES
void project_batch(const ShTables& t, const Batch& b, double* acc) {
  alignas(64) double w[6][kLanes];
  for_each_lm(
      t, b,
      [&](int m, const double* re, const double* im) {
        const double s = m == 0 ? 1.0 : std::numbers::sqrt2;
        for (int c = 0; c < 3; ++c) {
#pragma omp simd
          for (int i = 0; i < kLanes; ++i) {
            w[c][i] = s * re[i] * b.v[c][i];
            w[3 + c][i] = s * im[i] * b.v[c][i];
          }
        }
      },
      [&](int l, int m, const double* q) {
        // Sums over the batch kept as kWidth-wide partial sums (one SIMD register each), so
        // the loop vectorizes without reassociating floating-point adds; folded once at the end.
        alignas(64) double part[6][kWidth] = {};
        for (int i = 0; i < kLanes; i += kWidth)
          for (int c = 0; c < 6; ++c)
            for (int k = 0; k < kWidth; ++k) part[c][k] += q[i + k] * w[c][i + k];
        double sum[6];
        for (int c = 0; c < 6; ++c) {
          double t = 0;
          for (int k = 0; k < kWidth; ++k) t += part[c][k];
          sum[c] = t;
        }
        double* pos = acc + 3 * sh_index(l, m);
        pos[0] += sum[0], pos[1] += sum[1], pos[2] += sum[2];
        if (m > 0) {
          double* neg = acc + 3 * sh_index(l, -m);
          neg[0] += sum[3], neg[1] += sum[4], neg[2] += sum[5];
        }
      });
}

// b.v[c] = sum_lm coeff[lm][c] * Y_lm(dir)
ARLIGHT_SIMD_CLONES
void reconstruct_batch(const ShTables& t, const double* coeff, Batch& b) {
  alignas(64) double re_s[kLanes], im_s[kLanes];
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < kLanes; ++i) b.v[c][i] = 0.0;
  for_each_lm(
      t, b,
      [&](int m, const double* re, const double* im) {
        const double s = m == 0 ? 1.0 : std::numbers::sqrt2;
#pragma omp simd
        for (int i = 0; i < kLanes; ++i) re_s[i] = s * re[i], im_s[i] = s * im[i];
      },
      [&](int l, int m, const double* q) {
        const double* p = coeff + 3 * sh_index(l, m);
        const double* n = coeff + 3 * sh_index(l, -m);  // == p for m == 0, where im_s is 0
        const double p0 = p[0], p1 = p[1], p2 = p[2], n0 = n[0], n1 = n[1], n2 = n[2];
#pragma omp simd
        for (int i = 0; i < kLanes; ++i) {
          b.v[0][i] += q[i] * (re_s[i] * p0 + im_s[i] * n0);
          b.v[1][i] += q[i] * (re_s[i] * p1 + im_s[i] * n1);
          b.v[2][i] += q[i] * (re_s[i] * p2 + im_s[i] * n2);
        }
      });
}

// v[(k * 3 + c) * kLanes + i] = sum_lm coeff[k][lm][c] * Y_lm(dir_i) for `maps` expansions
// sharing one basis evaluation.
ARLIGHT_SIMD_CLONES
void reconstruct_batch_many(const ShTables& t, const std::vector<std::vector<double>>& coeff,
                            const Batch& b, double* v) {
  const int maps = int(coeff.size());
  alignas(64) double re_s[kLanes], im_s[kLanes], qa[kLanes], qb[kLanes];
  for (int i = 0; i < maps * 3 * kLanes; ++i) v[i] = 0.0;
  for_each_lm(
      t, b,
      [&](int m, const double* re, const double* im) {
        const double s = m == 0 ? 1.0 : std::numbers::sqrt2;
#pragma omp simd
        for (int i = 0; i < kLanes; ++i) re_s[i] = s * re[i], im_s[i] = s * im[i];
      },
      [&](int l, int m, const double* q) {
#pragma omp simd
        for (int i = 0; i < kLanes; ++i) qa[i] = q[i] * re_s[i], qb[i] = q[i] * im_s[i];
        for (int k = 0; k < maps; ++k) {
          const double* p = coeff[std::size_t(k)].data() + 3 * sh_index(l, m);
          const double* n = coeff[std::size_t(k)].data() + 3 * sh_index(l, -m);
          for (int c = 0; c < 3; ++c) {
            const double pc = p[c], nc = n[c];
            double* out = v + (k * 3 + c) * kLanes;
#pragma omp simd
            for (int i = 0; i < kLanes; ++i) out[i] += qa[i] * pc + qb[i] * nc;
          }
        }
      });
}

void fill_directions(const TexelTable& table, std::size_t first, Batch& b) {
  const std::size_t n = std::min<std::size_t>(kLanes, table.size() - first);
  b.count = int(n);
  for (std::size_t i = 0; i < std::size_t(kLanes); ++i) {
    const bool live = i < n;
    b.x[i] = live ? table.x[first + i] : 0.0;
    b.y[i] = live ? table.y[first + i] : 0.0;
    b.z[i] = live ? table.z[first + i] : 0.0;
  }
}

}  // namespace

void sh_basis_all(int order, glm::dvec3 dir, std::span<double> out) {
  const auto t = tables_for(order);
  if (out.size() < std::size_t(sh_count(order)))
    throw std::invalid_argument("sh_basis_all: output span too small");
  const glm::dvec3 d = unit(dir);
  double re = 1.0, im = 0.0;
  for (int m = 0; m < order; ++m) {
    if (m > 0) {
      const double r = re * d.x - im * d.y;
      im = re * d.y + im * d.x;
      re = r;
    }
    const double sr = m == 0 ? re : std::numbers::sqrt2 * re;
    const double si = std::numbers::sqrt2 * im;
    double q2 = 0.0, q1 = t->qmm[m];
    for (int l = m; l < order; ++l) {
      if (l > m) {
        const std::size_t k = t->column[m] + std::size_t(l - m - 1);
        const double q = t->a[k] * d.z * q1 - t->ab[k] * q2;
        q2 = q1, q1 = q;
      }
      out[std::size_t(sh_index(l, m))] = q1 * sr;
      if (m > 0) out[std::size_t(sh_index(l, -m))] = q1 * si;
    }
  }
}

double sh_basis(int l, int m, glm::dvec3 dir) {
  if (l < 0 || m < -l || m > l)
    throw std::invalid_argument("SH basis (l=" + std::to_string(l) + ", m=" + std::to_string(m) +
                                ") does not exist");
  // Tables of the next power-of-two order serve every band below it, so single-function
  // calls for many different bands share a handful of tables.
  const auto t = tables_for(int(std::bit_ceil(unsigned(l + 1))));
  const glm::dvec3 d = unit(dir);
  const int am = std::abs(m);
  double re = 1.0, im = 0.0;
  for (int k = 0; k < am; ++k) {
    const double r = re * d.x - im * d.y;
    im = re * d.y + im * d.x;
    re = r;
  }
  double q2 = 0.0, q1 = t->qmm[am];
  for (int k = am + 1; k <= l; ++k) {
    const std::size_t idx = t->column[am] + std::size_t(k - am - 1);
    const double q = t->a[idx] * d.z * q1 - t->ab[idx] * q2;
    q2 = q1, q1 = q;
  }
  if (m == 0) return q1;
  return std::numbers::sqrt2 * q1 * (m > 0 ? re : im);
}

void sh_legendre(int order, double z, std::span<double> out) {
  const auto t = tables_for(order);
  if (out.size() < std::size_t(order) * (order + 1) / 2)
    throw std::invalid_argument("sh_legendre: output span too small");
  if (!(z >= -1.0 && z <= 1.0)) throw std::invalid_argument("sh_legendre: z must be in [-1, 1]");
  const double sin_theta = std::sqrt((1.0 - z) * (1.0 + z));
  double sin_m = 1.0;
  for (int m = 0; m < order; ++m) {
    if (m > 0) sin_m *= sin_theta;
    double q2 = 0.0, q1 = t->qmm[m];
    for (int l = m; l < order; ++l) {
      if (l > m) {
        const std::size_t k = t->column[m] + std::size_t(l - m - 1);
        const double q = t->a[k] * z * q1 - t->ab[k] * q2;
        q2 = q1, q1 = q;
      }
      out[std::size_t(l) * (l + 1) / 2 + m] = q1 * sin_m;
    }
  }
}

ShCoeffs sh_project(const EnvMap& env, int order) {
  const auto t = tables_for(order);
  const auto table = texel_table(env.layout);
  const std::size_t n_coeff = std::size_t(sh_count(order));
  const std::size_t n_batches = (table->size() + kLanes - 1) / kLanes;
  // A fixed split into chunks, each with its own partial sums added in order at the end, makes
  // the result independent of the thread count and scheduling (bit-for-bit reproducible).
  const std::size_t budget = std::size_t(1) << 22;  // doubles of partial sums, 32 MiB
  const std::size_t n_chunks =
      std::max<std::size_t>(1, std::min({std::size_t(64), n_batches, budget / (3 * n_coeff)}));
  std::vector<double> partial(n_chunks * 3 * n_coeff, 0.0);
  const float* pixels = env.image.data();
  detail::parallel_for(std::size_t(0), n_chunks, [&](std::size_t chunk) {
    double* acc = partial.data() + chunk * 3 * n_coeff;
    Batch b;
    for (std::size_t batch = chunk * n_batches / n_chunks;
         batch < (chunk + 1) * n_batches / n_chunks; ++batch) {
      const std::size_t first = batch * kLanes;
      fill_directions(*table, first, b);
      for (int i = 0; i < kLanes; ++i) {
        const bool live = i < b.count;
        const double w = live ? table->solid_angle[first + i] : 0.0;
        const float* p = pixels + 3 * std::size_t(live ? table->index[first + i] : 0);
        for (int c = 0; c < 3; ++c) b.v[c][i] = w * p[c];
      }
      project_batch(*t, b, acc);
    }
  });
  ShCoeffs out(order);
  for (std::size_t chunk = 0; chunk < n_chunks; ++chunk)
    for (std::size_t k = 0; k < n_coeff; ++k)
      for (int c = 0; c < 3; ++c) out.c[k][c] += partial[(chunk * n_coeff + k) * 3 + c];
  return out;
}

void sh_accumulate(ShCoeffs& coeffs, std::span<const glm::dvec3> dirs,
                   std::span<const glm::dvec3> values) {
  if (dirs.size() != values.size())
    throw std::invalid_argument("sh_accumulate: " + std::to_string(dirs.size()) +
                                " directions but " + std::to_string(values.size()) + " values");
  const auto t = tables_for(coeffs.order);
  std::vector<double> acc(3 * coeffs.c.size(), 0.0);
  Batch b;
  for (std::size_t first = 0; first < dirs.size(); first += kLanes) {
    b.count = int(std::min<std::size_t>(kLanes, dirs.size() - first));
    for (int i = 0; i < kLanes; ++i) {
      const bool live = i < b.count;
      const glm::dvec3 d = live ? unit(dirs[first + i]) : glm::dvec3(0.0);
      const glm::dvec3 v = live ? values[first + i] : glm::dvec3(0.0);
      b.x[i] = d.x, b.y[i] = d.y, b.z[i] = d.z;
      b.v[0][i] = v.x, b.v[1][i] = v.y, b.v[2][i] = v.z;
    }
    project_batch(*t, b, acc.data());
  }
  for (std::size_t k = 0; k < coeffs.c.size(); ++k)
    for (int c = 0; c < 3; ++c) coeffs.c[k][c] += acc[3 * k + c];
}

std::array<float, 27> sh9_webxr(const ShCoeffs& sh) {
  if (sh.order < 3 || sh.c.size() < 9)
    throw std::invalid_argument("SH of order " + std::to_string(sh.order) +
                                ": SH-9 needs order 3 or more");
  std::array<float, 27> out{};
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c) out[std::size_t(3 * i + c)] = float(sh.c[std::size_t(i)][c]);
  return out;
}

DominantLight sh_dominant_light(const ShCoeffs& coeffs) {
  DominantLight light;
  if (coeffs.order < 2) return light;
  const auto band1 = [&](int c) {  // (x, y, z) components: Y_1^1 ~ x, Y_1^-1 ~ y, Y_1^0 ~ z
    return glm::dvec3(coeffs.at(1, 1)[c], coeffs.at(1, -1)[c], coeffs.at(1, 0)[c]);
  };
  const glm::dvec3 lum = luminance(band1(0), band1(1), band1(2));  // per component
  const double n = glm::length(lum);
  if (!(n > 1e-12)) return light;
  const glm::dvec3 d = lum / n;
  light.direction = glm::vec3(d);
  const double y1 = std::sqrt(3.0 / (4.0 * std::numbers::pi));  // |Y_1m| for a unit direction
  for (int c = 0; c < 3; ++c) light.colour[c] = float(std::max(0.0, glm::dot(band1(c), d) / y1));
  return light;
}

glm::dvec3 sh_evaluate(const ShCoeffs& coeffs, glm::dvec3 dir) {
  std::vector<double> y(std::size_t(sh_count(coeffs.order)));
  sh_basis_all(coeffs.order, dir, y);
  glm::dvec3 sum(0.0);
  for (std::size_t k = 0; k < y.size(); ++k) sum += coeffs.c[k] * y[k];
  return sum;
}

Image sh_reconstruct(const ShCoeffs& coeffs, const EnvLayout& layout) {
  const auto t = tables_for(coeffs.order);
  if (coeffs.c.size() != std::size_t(sh_count(coeffs.order)))
    throw std::invalid_argument(
        "SH coefficients: expected " + std::to_string(sh_count(coeffs.order)) + " for order " +
        std::to_string(coeffs.order) + ", got " + std::to_string(coeffs.c.size()));
  const auto table = texel_table(layout);
  std::vector<double> flat(coeffs.c.size() * 3);
  for (std::size_t k = 0; k < coeffs.c.size(); ++k)
    for (int c = 0; c < 3; ++c) flat[3 * k + c] = coeffs.c[k][c];
  Image out(layout.width(), layout.height());
  float* pixels = out.data();
  const std::size_t n_batches = (table->size() + kLanes - 1) / kLanes;
  detail::parallel_for(std::size_t(0), n_batches, [&](std::size_t batch) {
    Batch b;
    const std::size_t first = batch * kLanes;
    fill_directions(*table, first, b);
    reconstruct_batch(*t, flat.data(), b);
    for (int i = 0; i < b.count; ++i) {
      float* p = pixels + 3 * std::size_t(table->index[first + i]);
      for (int c = 0; c < 3; ++c) p[c] = float(b.v[c][i]);
    }
  });
  return out;
}

void sh_evaluate_many(std::span<const ShCoeffs> coeffs, std::span<const glm::dvec3> dirs,
                      std::span<float* const> out) {
  if (coeffs.empty()) return;
  if (out.size() != coeffs.size())
    throw std::invalid_argument("sh_evaluate_many: one output per expansion expected");
  const int order = coeffs[0].order;
  const auto t = tables_for(order);
  std::vector<std::vector<double>> flat;
  for (const ShCoeffs& k : coeffs) {
    if (k.order != order || k.c.size() != std::size_t(sh_count(order)))
      throw std::invalid_argument("sh_evaluate_many: expansions of different orders");
    std::vector<double>& f = flat.emplace_back(k.c.size() * 3);
    for (std::size_t i = 0; i < k.c.size(); ++i)
      for (int c = 0; c < 3; ++c) f[3 * i + std::size_t(c)] = k.c[i][c];
  }
  std::vector<double> v(coeffs.size() * 3 * kLanes);
  Batch b;
  for (std::size_t first = 0; first < dirs.size(); first += kLanes) {
    b.count = int(std::min<std::size_t>(kLanes, dirs.size() - first));
    for (int i = 0; i < kLanes; ++i) {
      const glm::dvec3 d = i < b.count ? unit(dirs[first + std::size_t(i)]) : glm::dvec3(0, 0, 1);
      b.x[i] = d.x, b.y[i] = d.y, b.z[i] = d.z;
    }
    reconstruct_batch_many(*t, flat, b, v.data());
    for (std::size_t k = 0; k < coeffs.size(); ++k)
      for (int i = 0; i < b.count; ++i)
        for (int c = 0; c < 3; ++c)
          out[k][3 * (first + std::size_t(i)) + std::size_t(c)] =
              float(v[(k * 3 + std::size_t(c)) * kLanes + std::size_t(i)]);
  }
}

ShCoeffs sh_convolve(const ShCoeffs& coeffs, std::span<const double> zonal) {
  if (zonal.size() < std::size_t(coeffs.order))
    throw std::invalid_argument("sh_convolve: need one zonal coefficient per band");
  ShCoeffs out = coeffs;
  for (int l = 0; l < coeffs.order; ++l)
    for (int m = -l; m <= l; ++m) out.at(l, m) *= zonal[std::size_t(l)];
  return out;
}

double phong_zonal(int l, double s) {
  if (l < 0) throw std::invalid_argument("phong_zonal: band must be >= 0");
  if (!(s >= 0.0) || !std::isfinite(s))
    throw std::invalid_argument("phong_zonal: shininess must be finite and >= 0");
  // Thesis Alg. 4.6 multiplies the numerator and denominator separately; at s = 1280 they pass
  // 1e308 by band ~100. A running product of the ratios stays in range and is exact otherwise.
  double v = 1.0;
  for (int i = (l % 2 == 1) ? 1 : 2; i <= l; i += 2) v *= (s - i + 2.0) / (s + i + 1.0);
  return v;
}

std::vector<double> phong_zonal_all(int order, double s) {
  std::vector<double> z(std::size_t(std::max(order, 0)));
  for (int l = 0; l < order; ++l) z[std::size_t(l)] = phong_zonal(l, s);
  return z;
}

std::vector<double> sh_cosine_lobe(glm::dvec3 n, int order) {
  std::vector<double> out(std::size_t(sh_count(order)));
  sh_basis_all(order, n, out);
  for (int l = 0; l < order; ++l) {
    const double z = phong_zonal(l, 1.0);
    for (int m = -l; m <= l; ++m) out[std::size_t(sh_index(l, m))] *= z;
  }
  return out;
}

ShCoeffs sh_rotate(const ShCoeffs& coeffs, const glm::dmat3& r) {
  if (coeffs.order < 1 || coeffs.c.size() != std::size_t(sh_count(coeffs.order)))
    throw std::invalid_argument("sh_rotate: coefficients do not match their order");
  // c'_k = integral of L(r w) Y_k(w) dw. The integrand is a polynomial of degree <= 2(N - 1) on
  // the sphere (rotation keeps each band), so Gauss-Legendre in z with N nodes times 2N uniform
  // angles in phi integrates it exactly.
  const int order = coeffs.order, n_phi = 2 * order;
  const GaussLegendre g = gauss_legendre(order);
  ShCoeffs out(order);
  std::vector<double> y(std::size_t(sh_count(order)));
  for (std::size_t i = 0; i < g.x.size(); ++i) {
    const double z = g.x[i], s = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j < n_phi; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / n_phi;
      const glm::dvec3 w(s * std::cos(phi), s * std::sin(phi), z);
      const glm::dvec3 l = sh_evaluate(coeffs, r * w) * (g.w[i] * 2.0 * kPi / n_phi);
      sh_basis_all(order, w, y);
      for (std::size_t k = 0; k < y.size(); ++k) out.c[k] += l * y[k];
    }
  }
  return out;
}

GaussLegendre gauss_legendre(int n) {
  if (n < 1) throw std::invalid_argument("gauss_legendre: need at least one node");
  GaussLegendre g{std::vector<double>(std::size_t(n)), std::vector<double>(std::size_t(n))};
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1, p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    const double w = 2.0 / ((1.0 - x * x) * dp * dp);
    g.x[std::size_t(i)] = -x, g.x[std::size_t(n - 1 - i)] = x;
    g.w[std::size_t(i)] = w, g.w[std::size_t(n - 1 - i)] = w;
  }
  return g;
}

}  // namespace arlight
