// The GGX-prefiltered radiance chain by a hierarchical sum (a Barnes-Hut tree code on the
// sphere; the exact sum it approximates is ggx_exact.cpp's).
//
// The GGX lobe has long tails (D falls as theta^-4 away from its peak): at roughness 0.13 a
// quarter of its weight lies beyond 3 degrees, and a bright window 90 degrees away still shows
// in a glossy texel. So no window can be cut off; instead the input's texels are grouped in a
// pyramid of cube-grid cells, and each output tile sums
//   - the input texels themselves near its lobes' axes (as Alg. 4.1's accurate method does), and
//   - further out, whole cells by their moments. The lobe is a function of c = R.l only, and
//     R.l = R.mu + R.(l - mu) exactly, so a second-order Taylor expansion in c about the cell's
//     centroid mu needs only the cell's sums: power, first moments per channel and the weights'
//     second moment (sum w (l-mu)(l-mu)^T). A cell of angular radius rho at angle d from the
//     tile is used whole when rho <= opening x max(d, lobe width) and a bound on the
//     expansion's error (its third-order remainder, and its second-order term where the cell's
//     radiance is uneven) is within 1 % of the tile's smallest sum, which a first pass over
//     cells alone bounds.
// Cells that straddle the horizon (R.l = 0, where the lobe has a kink) are opened down to a few
// degrees, and to their texels where a few bright texels (a sun) hold most of their power or
// where the kink could matter against that bound. The cost per output tile grows with the log
// of the input's texels plus the texels near the lobe's axis, instead of the whole input per
// output texel.
#include "arlight/lighting/ggx.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <limits>
#include <cmath>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "arlight/common/error.hpp"
#include "arlight/common/resample.hpp"
#include "ggx_detail.hpp"
#include "job.hpp"
#include "kernels.hpp"

namespace arlight::lighting {

namespace {

constexpr double kPi = std::numbers::pi;
// Cells that straddle some output's horizon are used whole only below this radius (rad): the
// kink of (R.l)+ there costs at most ~radius^2 / 2 of a cosine lobe's total.
constexpr double kHorizonRadius = 0.04;
// ... and only when no texel is brighter than this many times the cell's mean.
constexpr double kConcentration = 4.0;
// ... and only when its kink can change the sum by at most this share of the sum (per cell).
constexpr double kHorizonTolerance = 1e-3;
// Any cell is used whole only when the bound on its expansion's error is at most this share of
// the tile's smallest sum (the bound is loose: 1e-2 measured max errors <= 0.3 %, 1e-1 <= 0.6 %).
constexpr double kExpansionTolerance = 1e-2;
// The opening of the coarse pass (cells only) that bounds each tile's sums first.
constexpr double kFirstPassOpening = 0.5;
// Output tiles of 8 x 8 texels share one walk of the pyramid (4 measured 1.8x slower, 16 the same).
constexpr int kTileSize = 8;
// Texels to a finest cell, on average (1 and 2 measured slower).
constexpr double kTexelsPerCell = 4.0;

double angle_between(glm::dvec3 a, glm::dvec3 b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
}

// acos(x) to within 2e-8 rad (Abramowitz & Stegun 4.4.46): the pyramid walk's one
// transcendental per cell, ~4x cheaper than libm's. Cell radii carry a 1e-6 pad.
double fast_angle(double x) {
  const double ax = std::min(std::abs(x), 1.0);
  const double p =
      ((((((-0.0012624911 * ax + 0.0066700901) * ax - 0.0170881256) * ax + 0.0308918810) * ax -
         0.0501743046) * ax + 0.0889789874) * ax - 0.2145988016) * ax + 1.5707963050;
  const double r = std::sqrt(1.0 - ax) * p;
  return x >= 0.0 ? r : kPi - r;
}

// The input as a pyramid of cube-grid cells over its texels (the texels sorted by finest cell).
struct Pyramid {
  // Texels (single precision, structure of arrays), grouped by finest cell.
  std::vector<float> x, y, z, w, lr, lg, lb;

  // Cells of every level, from the finest (level 0, a cube grid of `finest` cells a face edge)
  // to the coarsest (1 cell a face); level k has finest >> k cells a face edge.
  struct Cell {
    double weight = 0.0;            // sum w
    glm::dvec3 sum_dir{0.0};        // sum w l
    glm::dvec3 power{0.0};          // sum L w
    glm::dvec3 centroid{0.0, 0.0, 1.0};  // normalize(sum_dir)
    glm::dvec3 m1_weight{0.0};      // sum w (l - mu)
    glm::dvec3 m1[3]{};             // per channel: sum L_c w (l - mu)
    glm::dmat3 m2{0.0};             // sum w (l - mu)(l - mu)^T
    double radius = 0.0;            // every texel within this angle of mu
    double peak = 0.0;              // the largest radiance of a texel, any channel
    // Whether a few texels hold most of the cell's power (a sun, a lamp): then the cell's
    // moments do not say how much of it lies beyond a horizon.
    bool concentrated() const {
      return peak * weight > kConcentration * std::max({power.x, power.y, power.z});
    }
    std::uint32_t begin = 0, end = 0;  // finest cells: their texels
  };
  int finest = 1;
  std::vector<int> level_face;       // cells a face edge, per level
  std::vector<std::size_t> level_offset;
  std::vector<Cell> cells;

  std::size_t cell_index(int level, int face, int i, int j) const {
    const auto g = std::size_t(level_face[std::size_t(level)]);
    return level_offset[std::size_t(level)] + (std::size_t(face) * g + std::size_t(j)) * g +
           std::size_t(i);
  }
};

// Moves the moments of `c` (about its own centroid) to be about `mu`.
void shift_moments(const Pyramid::Cell& c, glm::dvec3 mu, Pyramid::Cell& into) {
  const glm::dvec3 d = c.centroid - mu;
  into.m1_weight += c.m1_weight + c.weight * d;
  for (int ch = 0; ch < 3; ++ch) into.m1[ch] += c.m1[ch] + c.power[ch] * d;
  into.m2 += c.m2 + glm::outerProduct(c.m1_weight, d) + glm::outerProduct(d, c.m1_weight) +
             c.weight * glm::outerProduct(d, d);
}

Pyramid build_pyramid(const EnvMap& input) {
  const TexelTable& table = *texel_table(input.layout);
  Pyramid p;
  const double target = std::sqrt(double(table.size()) / (6.0 * kTexelsPerCell));
  p.finest = int(std::bit_floor(unsigned(std::max(1.0, target))));
  const EnvLayout grid(Projection::Cube, p.finest, 6 * p.finest);

  // Sort the valid texels by finest cell.
  const float* px = input.image.data();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> keyed;  // (cell, table entry)
  keyed.reserve(table.size());
  for (std::size_t e = 0; e < table.size(); ++e) {
    if (table.solid_angle[e] <= 0.0) continue;
    const glm::dvec3 d(table.x[e], table.y[e], table.z[e]);
    const glm::ivec2 t = grid.dir_to_texel(d);
    keyed.emplace_back(std::uint32_t(t.y) * std::uint32_t(p.finest) + std::uint32_t(t.x),
                       std::uint32_t(e));
  }
  std::sort(keyed.begin(), keyed.end());

  for (int g = p.finest; g >= 1; g /= 2) {
    p.level_offset.push_back(p.cells.size());
    p.level_face.push_back(g);
    p.cells.resize(p.cells.size() + 6 * std::size_t(g) * std::size_t(g));
  }
  const std::size_t n = keyed.size();
  for (auto* v : {&p.x, &p.y, &p.z, &p.w, &p.lr, &p.lg, &p.lb}) v->resize(n);

  // Finest cells from their texels: sums, then moments about the centroid.
  for (std::size_t k = 0; k < n;) {
    const std::uint32_t id = keyed[k].first;
    Pyramid::Cell& c = p.cells[id];
    c.begin = std::uint32_t(k);
    std::size_t end = k;
    for (; end < n && keyed[end].first == id; ++end) {
      const std::size_t e = keyed[end].second;
      const glm::dvec3 d(table.x[e], table.y[e], table.z[e]);
      const double w = table.solid_angle[e];
      const float* l = px + 3 * std::size_t(table.index[e]);
      c.weight += w;
      c.sum_dir += w * d;
      c.power += w * glm::dvec3(l[0], l[1], l[2]);
      p.x[end] = float(d.x), p.y[end] = float(d.y), p.z[end] = float(d.z), p.w[end] = float(w);
      p.lr[end] = float(l[0] * w), p.lg[end] = float(l[1] * w), p.lb[end] = float(l[2] * w);
    }
    c.end = std::uint32_t(end);
    c.centroid = glm::normalize(c.sum_dir);
    for (std::size_t i = k; i < end; ++i) {
      const std::size_t e = keyed[i].second;
      const glm::dvec3 d(table.x[e], table.y[e], table.z[e]);
      const glm::dvec3 delta = d - c.centroid;
      const double w = p.w[i];
      c.m1_weight += w * delta;
      c.m1[0] += double(p.lr[i]) * delta;
      c.m1[1] += double(p.lg[i]) * delta;
      c.m1[2] += double(p.lb[i]) * delta;
      c.m2 += w * glm::outerProduct(delta, delta);
      c.radius = std::max(c.radius, angle_between(c.centroid, d));
      const float* l = px + 3 * std::size_t(table.index[e]);
      c.peak = std::max(c.peak, double(std::max({l[0], l[1], l[2]})));
    }
    c.radius += 1e-6;
    k = end;
  }
  // Coarser levels from their four children.
  for (std::size_t level = 1; level < p.level_face.size(); ++level) {
    const int g = p.level_face[level];
    for (int face = 0; face < 6; ++face)
      for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
          Pyramid::Cell& c = p.cells[p.cell_index(int(level), face, i, j)];
          std::array<const Pyramid::Cell*, 4> kids;
          for (int q = 0; q < 4; ++q)
            kids[std::size_t(q)] =
                &p.cells[p.cell_index(int(level) - 1, face, 2 * i + (q & 1), 2 * j + (q >> 1))];
          for (const Pyramid::Cell* k : kids) {
            c.weight += k->weight;
            c.sum_dir += k->sum_dir;
            c.power += k->power;
          }
          if (c.weight <= 0.0) continue;
          c.centroid = glm::normalize(c.sum_dir);
          for (const Pyramid::Cell* k : kids) {
            if (k->weight <= 0.0) continue;
            shift_moments(*k, c.centroid, c);
            c.radius = std::max(c.radius, angle_between(c.centroid, k->centroid) + k->radius);
            c.peak = std::max(c.peak, k->peak);
          }
        }
  }
  return p;
}

// The near and far parts of one output tile's sum, gathered by walking the pyramid.
struct Interactions {
  // Texels: x, y, z, w, lr, lg, lb.
  std::array<std::vector<float>, 7> texels;
  // Cells: centroid (3), weight, power (3), mean radiance (3), m1_weight (3), m1 (9), m2 (6:
  // xx, yy, zz, xy, xz, yz).
  static constexpr int kCellFloats = 28;
  std::array<std::vector<float>, kCellFloats> cells;
  void clear() {
    for (auto& v : texels) v.clear();
    for (auto& v : cells) v.clear();
  }
  void add_texels(const Pyramid& p, std::uint32_t begin, std::uint32_t end) {
    const std::array<const std::vector<float>*, 7> src{&p.x, &p.y, &p.z, &p.w, &p.lr, &p.lg, &p.lb};
    for (std::size_t a = 0; a < 7; ++a)
      texels[a].insert(texels[a].end(), src[a]->begin() + begin, src[a]->begin() + end);
  }
  void add_cell(const Pyramid::Cell& c) {
    const glm::dvec3 mean = c.power / c.weight;
    const float v[kCellFloats] = {
        float(c.centroid.x), float(c.centroid.y), float(c.centroid.z), float(c.weight),
        float(c.power.x), float(c.power.y), float(c.power.z),
        float(mean.x), float(mean.y), float(mean.z),
        float(c.m1_weight.x), float(c.m1_weight.y), float(c.m1_weight.z),
        float(c.m1[0].x), float(c.m1[0].y), float(c.m1[0].z),
        float(c.m1[1].x), float(c.m1[1].y), float(c.m1[1].z),
        float(c.m1[2].x), float(c.m1[2].y), float(c.m1[2].z),
        float(c.m2[0][0]), float(c.m2[1][1]), float(c.m2[2][2]),
        float(c.m2[0][1]), float(c.m2[0][2]), float(c.m2[1][2])};
    for (int a = 0; a < kCellFloats; ++a) cells[std::size_t(a)].push_back(v[a]);
  }
};

// The GGX lobe as a function of u = 1 - R.l (computed as |R - l|^2 / 2, exact in floats near
// the peak): f = c / t^2 with c = 1 - u and t = alpha^2 + u (1 - alpha^2) / 2, i.e. D(h) (R.l)
// up to a constant (n.h^2 = 1 - u / 2). Its derivatives in c: f' = (t + 2ck) / t^3 and
// f'' = (4kt + 6ck^2) / t^4 with k = (1 - alpha^2) / 2 = -dt/dc.
struct Lobe {
  float a2, k;
};

#if defined(__clang__)
#define ARLIGHT_GGX_CLONES  // clang's builds (sanitizers, fuzzing) keep one version
#else
// One version per instruction set, chosen at load time (as kernels.cpp does): the sums are
// ~2/3 of the chain's time and vectorise 8 or 16 floats wide.
#define ARLIGHT_GGX_CLONES __attribute__((target_clones("avx512f", "fma", "default")))
#endif

// Sums the tile's interactions for one output direction: acc = (sum f L w, sum f w).
ARLIGHT_GGX_CLONES void sum_direction(const Interactions& in, const Lobe& lobe, glm::vec3 r, double acc[4]) {
  const float a2 = lobe.a2, k = lobe.k;
  const float rx = r.x, ry = r.y, rz = r.z;
  {
    const float *x = in.texels[0].data(), *y = in.texels[1].data(), *z = in.texels[2].data(),
                *w = in.texels[3].data(), *lr = in.texels[4].data(), *lg = in.texels[5].data(),
                *lb = in.texels[6].data();
    const std::size_t n = in.texels[0].size();
    for (std::size_t b = 0; b < n; b += 1024) {
      const std::size_t e = std::min(n, b + 1024);
      float sr = 0, sg = 0, sb = 0, sw = 0;
#pragma omp simd reduction(+ : sr, sg, sb, sw)
      for (std::size_t i = b; i < e; ++i) {
        const float dx = rx - x[i], dy = ry - y[i], dz = rz - z[i];
        const float u = 0.5f * (dx * dx + dy * dy + dz * dz);
        const float c = 1.0f - u;
        const float t = a2 + u * k;
        const float f = c > 0.0f ? c / (t * t) : 0.0f;
        sr += f * lr[i];
        sg += f * lg[i];
        sb += f * lb[i];
        sw += f * w[i];
      }
      acc[0] += sr, acc[1] += sg, acc[2] += sb, acc[3] += sw;
    }
  }
  const auto& cv = in.cells;
  const float *mx = cv[0].data(), *my = cv[1].data(), *mz = cv[2].data(), *cw = cv[3].data(),
              *pr = cv[4].data(), *pg = cv[5].data(), *pb = cv[6].data(), *ar = cv[7].data(),
              *ag = cv[8].data(), *ab = cv[9].data(), *wx = cv[10].data(), *wy = cv[11].data(),
              *wz = cv[12].data(), *rx1 = cv[13].data(), *ry1 = cv[14].data(),
              *rz1 = cv[15].data(), *gx1 = cv[16].data(), *gy1 = cv[17].data(),
              *gz1 = cv[18].data(), *bx1 = cv[19].data(), *by1 = cv[20].data(),
              *bz1 = cv[21].data(), *qxx = cv[22].data(), *qyy = cv[23].data(),
              *qzz = cv[24].data(), *qxy = cv[25].data(), *qxz = cv[26].data(),
              *qyz = cv[27].data();
  const float rxx = rx * rx, ryy = ry * ry, rzz = rz * rz, rxy = 2 * rx * ry, rxz = 2 * rx * rz,
              ryz = 2 * ry * rz;
  const std::size_t n = cv[0].size();
  for (std::size_t b = 0; b < n; b += 1024) {
    const std::size_t e = std::min(n, b + 1024);
    float sr = 0, sg = 0, sb = 0, sw = 0;
#pragma omp simd reduction(+ : sr, sg, sb, sw)
    for (std::size_t i = b; i < e; ++i) {
      const float dx = rx - mx[i], dy = ry - my[i], dz = rz - mz[i];
      const float u = 0.5f * (dx * dx + dy * dy + dz * dz);
      const float c = 1.0f - u;
      const float t = a2 + u * k;
      const float it = 1.0f / t;
      const float it2 = it * it;
      const float f = c * it2;
      const float f1 = (t + 2.0f * c * k) * it2 * it;
      const float f2 = (4.0f * k * t + 6.0f * c * k * k) * it2 * it2;
      const float q = rxx * qxx[i] + ryy * qyy[i] + rzz * qzz[i] + rxy * qxy[i] + rxz * qxz[i] +
                      ryz * qyz[i];
      const float h = 0.5f * f2 * q;
      const float above = c > 0.0f ? 1.0f : 0.0f;
      sw += above * (f * cw[i] + f1 * (rx * wx[i] + ry * wy[i] + rz * wz[i]) + h);
      sr += above * (f * pr[i] + f1 * (rx * rx1[i] + ry * ry1[i] + rz * rz1[i]) + h * ar[i]);
      sg += above * (f * pg[i] + f1 * (rx * gx1[i] + ry * gy1[i] + rz * gz1[i]) + h * ag[i]);
      sb += above * (f * pb[i] + f1 * (rx * bx1[i] + ry * by1[i] + rz * bz1[i]) + h * ab[i]);
    }
    acc[0] += sr, acc[1] += sg, acc[2] += sb, acc[3] += sw;
  }
}

// Collects the tile's interactions: cells far enough from the tile's cone (centre, radius tau)
// for their moments, texels elsewhere.
// A straddling cell is used whole only when it is small, not concentrated, and the most its
// kink can change the sum (its power x radius x the lobe's slope at the horizon) is within
// `horizon_budget`.
void gather(const Pyramid& p, glm::dvec3 centre, double tau, double sigma, double opening,
            double horizon_slope, double horizon_budget, const Lobe& lobe, double expansion_budget,
            double expansion_weight_budget, bool open_to_texels, Interactions& out) {
  const double a2 = lobe.a2, k = lobe.k;
  out.clear();
  struct Item {
    int level, face, i, j;
  };
  std::vector<Item> stack;
  const int top = int(p.level_face.size()) - 1;
  for (int face = 0; face < 6; ++face) stack.push_back({top, face, 0, 0});
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const Pyramid::Cell& c = p.cells[p.cell_index(it.level, it.face, it.i, it.j)];
    if (c.weight <= 0.0) continue;
    const double a = fast_angle(glm::dot(centre, c.centroid));
    const double dmin = a - tau - c.radius, dmax = a + tau + c.radius;
    if (dmin >= kPi / 2) continue;  // below every output's horizon
    const bool straddles = dmax > kPi / 2;
    const double pmax = std::max({c.power.x, c.power.y, c.power.z});
    bool whole = !open_to_texels && it.level == 0;
    if (!whole && c.radius <= opening * std::max(dmin, sigma) &&
        (!straddles || (c.radius <= kHorizonRadius && !c.concentrated() &&
                        pmax * c.radius * horizon_slope <= horizon_budget))) {
      // What using the cell whole can cost at most: the expansion's third-order remainder, and
      // its second-order term where the radiance is uneven (it takes the cell's mean radiance).
      whole = true;
      if (expansion_budget < std::numeric_limits<double>::infinity()) {
        const double c_hi = std::cos(std::max(dmin, 0.0)), t = a2 + k * (1.0 - c_hi);
        const double f2 = (4.0 * k * t + 6.0 * c_hi * k * k) / (t * t * t * t);
        const double f3 = (18.0 * k * k * t + 24.0 * c_hi * k * k * k) / (t * t * t * t * t);
        const double uneven =
            pmax > 0.0 ? std::clamp((c.peak * c.weight / pmax - 1.0) / 3.0, 0.0, 1.0) : 0.0;
        // |R.(l - mu)| <= rho sin(angle) + rho^2 / 2 over the cell: its extent in c.
        const double r = c.radius * std::sin(std::min(dmax, kPi / 2)) + 0.5 * c.radius * c.radius;
        const double third = f3 * r * r * r / 6.0;
        // The same bound on the weights' sum (the ratio's denominator: a dark cell's weight
        // counts too), against the tile's smallest weight sum.
        whole = pmax * (third + uneven * 0.5 * f2 * r * r) <= expansion_budget &&
                c.weight * third <= expansion_weight_budget;
      }
    }
    if (whole) {
      out.add_cell(c);
    } else if (it.level == 0) {
      out.add_texels(p, c.begin, c.end);
    } else {
      for (int q = 0; q < 4; ++q)
        stack.push_back({it.level - 1, it.face, 2 * it.i + (q & 1), 2 * it.j + (q >> 1)});
    }
  }
}

void check_input(const EnvMap& input) {
  const auto& s = input.image.storage();
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!std::isfinite(s[i]) || s[i] < 0.0f)
      throw InputError("GGX prefilter: the input has a negative or non-finite value at texel " +
                       std::to_string(i / 3) + " (sanitize it first)");
}

// The prefilter at `roughness` in `output`; with `redo` (one flag per tile of
// detail::ggx_tiles(output)) only the flagged tiles, the others copied from `previous`.
EnvMap prefilter(const Pyramid& pyramid, double roughness, const EnvLayout& output,
                 double opening, int map_index, detail::Progress& progress,
                 const std::vector<char>* redo = nullptr, const EnvMap* previous = nullptr) {
  if (!(roughness > 0.0 && roughness <= 1.0))
    throw InputError("GGX prefilter: roughness must lie in (0, 1], got " + std::to_string(roughness));
  if (!(opening > 0.0 && opening < 1.0))
    throw InputError("GGX prefilter: opening must lie in (0, 1), got " + std::to_string(opening));
  const double alpha = roughness * roughness;
  const Lobe lobe{float(alpha * alpha), float((1.0 - alpha * alpha) / 2.0)};
  // The lobe's angular scale: t doubles from its peak value at theta ~ 2 alpha.
  const double sigma = 2.0 * alpha;
  // f'(0), the lobe's slope in c at the horizon.
  const double horizon_slope = 1.0 / (double(lobe.a2 + lobe.k) * double(lobe.a2 + lobe.k));
  const detail::OutputTexels texels_of = detail::ggx_tiles(output);
  EnvMap result = previous ? *previous : EnvMap(output);
  const auto& tiles = texels_of.tiles();
  tbb::enumerable_thread_specific<Interactions> scratch;
  tbb::parallel_for(std::size_t(0), tiles.size(), [&](std::size_t ti) {
    if (redo && !(*redo)[ti]) return;
    progress.check();
    detail::FlushDenormals ftz;
    const detail::Tile& tile = tiles[ti];
    const detail::TileTexels texels = texels_of.collect(tile);
    if (texels.dirs.empty()) return;
    const auto [centre, tau] = detail::tile_cone(texels);
    Interactions& in = scratch.local();
    // A coarse first pass bounds the tile's sums from below; the second spends on the horizon
    // and on the cells' expansions only what that bound says can matter.
    constexpr double kNone = std::numeric_limits<double>::infinity();
    gather(pyramid, centre, tau, sigma, kFirstPassOpening, horizon_slope, kNone, lobe, kNone,
           kNone, false, in);
    double least = std::numeric_limits<double>::infinity(), least_weight = least;
    for (const glm::dvec3& d : texels.dirs) {
      double acc[4] = {0, 0, 0, 0};
      sum_direction(in, lobe, glm::vec3(d), acc);
      const double top = std::max({acc[0], acc[1], acc[2]});
      least = std::min(least, std::max(std::min({acc[0], acc[1], acc[2]}), 0.01 * top));
      least_weight = std::min(least_weight, acc[3]);
    }
    gather(pyramid, centre, tau, sigma, opening, horizon_slope,
           kHorizonTolerance * std::max(least, 0.0), lobe, kExpansionTolerance * std::max(least, 0.0),
           kExpansionTolerance * std::max(least_weight, 0.0), true, in);
    float* out = result.image.data();
    for (std::size_t i = 0; i < texels.dirs.size(); ++i) {
      double acc[4] = {0, 0, 0, 0};
      sum_direction(in, lobe, glm::vec3(texels.dirs[i]), acc);
      for (int ch = 0; ch < 3; ++ch)
        out[3 * texels.pixels[i] + std::size_t(ch)] =
            acc[3] > 0.0 ? float(std::max(0.0, acc[ch] / acc[3])) : 0.0f;
    }
    progress.tile_done(map_index, tile);
  });
  progress.check();
  return result;
}

}  // namespace

std::vector<EnvMap> ggx_prefilter(const EnvMap& input, std::span<const double> roughness,
                                  const EnvLayout& output, double opening, const Hooks& hooks) {
  check_input(input);
  const Pyramid pyramid = build_pyramid(input);
  detail::Progress progress(hooks, roughness.size() * detail::ggx_tiles(output).tiles().size());
  std::vector<EnvMap> maps;
  for (std::size_t k = 0; k < roughness.size(); ++k)
    maps.push_back(prefilter(pyramid, roughness[k], output, opening, int(k), progress));
  return maps;
}

EnvMap ggx_prefilter(const EnvMap& input, double roughness, const EnvLayout& output,
                     double opening, const Hooks& hooks) {
  return std::move(ggx_prefilter(input, std::span(&roughness, 1), output, opening, hooks)[0]);
}

namespace detail {

OutputTexels ggx_tiles(const EnvLayout& output) { return OutputTexels(output, kTileSize); }

TileCone tile_cone(const TileTexels& texels) {
  if (texels.dirs.empty()) return {};
  glm::dvec3 sum(0.0);
  for (const glm::dvec3& d : texels.dirs) sum += d;
  const glm::dvec3 centre = glm::length(sum) > 1e-9 ? glm::normalize(sum) : texels.dirs.front();
  double tau = 0.0;
  for (const glm::dvec3& d : texels.dirs) tau = std::max(tau, angle_between(centre, d));
  return {centre, tau + 1e-6};
}

int ggx_chain_levels(const GgxChainSpec& spec) {
  if (spec.face < 1 || !std::has_single_bit(unsigned(spec.face)))
    throw InputError("GGX chain: the face size must be a power of two, got " + std::to_string(spec.face));
  if (spec.min_face < 1 || spec.min_face > spec.face || !std::has_single_bit(unsigned(spec.min_face)))
    throw InputError("GGX chain: the smallest face must be a power of two from 1 to the face size (" +
                     std::to_string(spec.face) + "), got " + std::to_string(spec.min_face));
  return std::countr_zero(unsigned(spec.face)) - std::countr_zero(unsigned(spec.min_face)) + 1;
}

double ggx_lobe_value(double roughness, double cos_angle) {
  if (!(cos_angle > 0.0)) return 0.0;
  const double alpha = roughness * roughness, a2 = alpha * alpha, k = (1.0 - a2) / 2.0;
  const double t = a2 + (1.0 - cos_angle) * k;
  return cos_angle / (t * t);
}

double ggx_lobe_integral(double roughness) {
  const double alpha = roughness * roughness, a2 = alpha * alpha, k = (1.0 - a2) / 2.0;
  // 2 pi x integral over c in [0, 1] of c / (a2 + (1 - c) k)^2; with s = a2 + (1 - c) k it is
  // (1 / k) [(1 + a2 / k)(1 / a2 - 1 / (a2 + k)) - ln((a2 + k) / a2) / k].
  if (k < 1e-6) return std::numbers::pi / (a2 * a2);  // r = 1: the cosine lobe / a2^2
  const double b = a2 + k;
  return 2.0 * std::numbers::pi / k *
         ((1.0 + a2 / k) * (1.0 / a2 - 1.0 / b) - std::log(b / a2) / k);
}

GgxChain ggx_chain(const EnvMap& input, const GgxChainSpec& spec, const Hooks& hooks,
                   const GgxChain* previous, const std::vector<std::vector<char>>* redo) {
  const int levels = ggx_chain_levels(spec);
  check_input(input);
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t total = 0;
  for (int k = 1; k < levels; ++k) {
    const int f = spec.face >> k;
    if (redo)
      total += std::size_t(std::count((*redo)[std::size_t(k)].begin(), (*redo)[std::size_t(k)].end(), 1));
    else
      total += ggx_tiles(EnvLayout(Projection::Cube, f, 6 * f)).tiles().size();
  }
  Progress progress(hooks, std::max<std::size_t>(total, 1));
  GgxChain chain;
  {
    const auto t = std::chrono::steady_clock::now();
    const EnvLayout mirror_layout(Projection::Cube, spec.face, 6 * spec.face);
    GgxLevel mirror{0, 0.0,
                    input.layout == mirror_layout ? input : resample(input, mirror_layout), 0.0};
    mirror.seconds = seconds_since(t);
    chain.levels.push_back(std::move(mirror));
  }
  const auto tp = std::chrono::steady_clock::now();
  const Pyramid pyramid = build_pyramid(input);
  const double pyramid_seconds = seconds_since(tp);
  for (int k = 1; k < levels; ++k) {
    const auto t = std::chrono::steady_clock::now();
    const int f = spec.face >> k;
    const double r = ggx_level_roughness(k, levels);
    EnvMap map = prefilter(pyramid, r, EnvLayout(Projection::Cube, f, 6 * f), spec.opening, k,
                           progress, redo ? &(*redo)[std::size_t(k)] : nullptr,
                           previous ? &previous->levels[std::size_t(k)].map : nullptr);
    // The pyramid serves every level; its build counts towards the first.
    const double s = seconds_since(t) + (k == 1 ? pyramid_seconds : 0.0);
    chain.levels.push_back({k, r, std::move(map), s});
  }
  chain.total_seconds = seconds_since(t0);
  return chain;
}

}  // namespace detail

GgxChain compute_ggx_chain(const EnvMap& input, const GgxChainSpec& spec, const Hooks& hooks) {
  return detail::ggx_chain(input, spec, hooks, nullptr, nullptr);
}

}  // namespace arlight::lighting
