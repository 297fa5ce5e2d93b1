// Irradiance and reflection maps of an HDR environment map (thesis ch. 4, §2.3, §6.2).
//
// Map values follow thesis Alg. 4.1: texel d of the map for shininess s holds the lobe-weighted
// average of incident radiance, sum L(w) f(w) dw / sum f(w) dw with f = max(0, d.w)^s, so a
// constant environment gives that constant in every map. s = 1 is the irradiance map (stored as
// the cosine-weighted mean radiance, i.e. irradiance / pi, indexed by the normal), s > 1 a Phong
// reflection map indexed by the reflected direction.
#pragma once

#include <functional>
#include <span>
#include <stdexcept>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/projection.hpp"

namespace arlight::lighting {

enum class Method {
  Accurate,    // brute force over every input texel (Alg. 4.1), the reference
  Mipmap,      // MIP-map level lookups (§4.2, eqs. 4.1-4.3), as the thesis did it
  Sh,          // SH convolution (Alg. 4.5-4.7) at a chosen order
  Bounded,     // Alg. 4.1 over the lobe's window only (§6.2.2, with derived bounds)
  Importance,  // Monte-Carlo with importance sampling and MIP-filtered lookups ([CK07], §2.3)
  Auto,        // per shininess, the cheapest plan that meets an error target
};

// How finely Method::Auto resolves each lobe (defaults measured to meet ErrorTarget; see
// auto.cpp). Both are in texel spacings per lobe standard deviation.
struct AutoTuning {
  double input_per_sigma = 3.0;   // spacing of the prefiltered input it integrates
  double output_per_sigma = 2.5;  // spacing of the grid it evaluates and interpolates
};

struct MethodSpec {
  Method method = Method::Auto;
  int sh_order = 35;  // Method::Sh
  int samples = 64;   // Method::Importance: lobe samples per texel
  AutoTuning tuning;  // Method::Auto

  // The name parse_method() reads back: "accurate", "sh:35", "importance:64", ...
  std::string name() const;
};

// Reads "accurate", "mipmap", "sh", "sh:N", "bounded", "importance", "importance:K", "auto".
// A bare "sh" / "importance" takes the given default. Throws InputError naming the method and
// the valid names.
MethodSpec parse_method(std::string_view text, int default_sh_order = 35, int default_samples = 64);

// Reports a finished output tile of one map. Tiles are rectangles of the output image.
struct TileDone {
  int map = 0;  // index into the requested shininess list
  int x = 0, y = 0, width = 0, height = 0;
  std::size_t done = 0, total = 0;  // tiles finished so far / in all, over all maps
};

struct Hooks {
  // Called once per finished tile and map, never concurrently (calls are serialised), from
  // the computing threads: keep it short.
  std::function<void(const TileDone&)> on_tile;
  // When stop is requested, compute_maps() abandons the work and throws Cancelled.
  std::stop_token stop;
};

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("map computation cancelled") {}
};

struct MapSet {
  std::vector<double> shininess;  // as requested
  std::vector<EnvMap> maps;       // one per shininess, in `output`'s layout
  // Wall seconds per map. Methods that compute all maps in one pass (accurate, bounded, sh,
  // mipmap, importance) share that pass's time equally between its maps.
  std::vector<double> seconds;
  std::vector<std::string> plans;  // how each map was made (auto's choice, with its numbers)
  double total_seconds = 0.0;
};

// Computes one map per shininess (each >= 1) of `input` in `output`'s layout, on all cores.
// Input and output may use any projection and size. Throws std::invalid_argument for s < 1 or
// an empty list, Cancelled when hooks.stop is requested.
MapSet compute_maps(const EnvMap& input, std::span<const double> shininess, const EnvLayout& output,
                    const MethodSpec& method, const Hooks& hooks = {});

// Errors of `test` against `reference` (same layout) over every valid texel and channel, as
// fractions: thesis eq. 6.1 (mean of |a - v| / (a + eps)) and eq. 6.2 (max of the same), with
// eps = 1e-4 x the reference's mean so black texels do not divide by zero.
struct MapError {
  double mean = 0.0;
  double max = 0.0;
};
MapError map_error(const EnvMap& reference, const EnvMap& test);

}  // namespace arlight::lighting
