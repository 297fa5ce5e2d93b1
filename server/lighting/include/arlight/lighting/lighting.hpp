// Irradiance and reflection maps of an HDR environment map (thesis ch. 4, §2.3, §6.2).
//
// Map values follow thesis Alg. 4.1: texel d of the map for shininess s holds the lobe-weighted
// average of incident radiance, sum L(w) f(w) dw / sum f(w) dw with f = max(0, d.w)^s, so a
// constant environment gives that constant in every map. s = 1 is the irradiance map (stored as
// the cosine-weighted mean radiance, i.e. irradiance / pi, indexed by the normal), s > 1 a Phong
// reflection map indexed by the reflected direction.
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include "arlight/common/projection.hpp"

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
  // Called between tiles from the computing threads (concurrently): it may block for a while
  // to let more urgent work have the cores (arlightd: a session's frames, issue 37 §2).
  std::function<void()> step_aside;
};

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("map computation cancelled") {}
};

struct ComputedMapSet {
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
ComputedMapSet compute_maps(const EnvMap& input, std::span<const double> shininess, const EnvLayout& output,
                    const MethodSpec& method, const Hooks& hooks = {});

// Maps that follow an environment as it changes (issue 16 §3: map sets at 10 Hz while a phone
// captures). Each update() takes the environment as it is now, in the same layout as the last
// one, and with method auto recomputes only what its changes reach:
// - an input texel counts as changed when one of its channels moved by more than `tolerance`
//   relative to its value (plus tolerance x 0.1 of the map's mean luminance, so dark noise does
//   not count) since it last counted; changed texels are grouped in cones;
// - maps made by direct sums (narrow lobes) recompute only the 8x8 blocks of output texels or
//   cube-grid points whose lobe windows reach a changed cone, and re-interpolate their grids;
// - maps made through SH (wide lobes, whose windows reach most of the sphere) are recomputed
//   whole after any change.
// A map texel not recomputed was computed from an input that differs from today's by at most
// about 2 x tolerance in its window, so it is within that of a fresh computation. Other methods,
// a new input layout, and the first update compute everything (as compute_maps). An update that
// is cancelled or fails leaves the next one to compute everything.
class MapUpdater {
 public:
  MapUpdater(std::vector<double> shininess, const EnvLayout& output, MethodSpec method = {},
             double tolerance = 0.02);
  ~MapUpdater();
  MapUpdater(MapUpdater&&) noexcept;
  MapUpdater& operator=(MapUpdater&&) noexcept;

  // Throws as compute_maps does. `measured`, when given (one value per texel of the input's
  // layout, row-major), is the share of each texel that was measured rather than estimated
  // (a capture's fill): an estimated texel counts as changed only past kEstimatedTolerance x
  // the tolerance, as an estimate that moves a little says little about the room.
  const ComputedMapSet& update(const EnvMap& input, const Hooks& hooks = {},
                       std::span<const float> measured = {});
  static constexpr double kEstimatedTolerance = 2.5;
  // Of the last update: the share of each map's output recomputed (1: all of it) and of the
  // input's texels that counted as changed.
  std::span<const double> recomputed() const;
  double changed() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Errors of `test` against `reference` (same layout) over every valid texel and channel, as
// fractions: thesis eq. 6.1 (mean of |a - v| / (a + eps)) and eq. 6.2 (max of the same), with
// eps = 1e-4 x the reference's mean so black texels do not divide by zero.
struct MapError {
  double mean = 0.0;
  double max = 0.0;
};
MapError map_error(const EnvMap& reference, const EnvMap& test);

}  // namespace arlight::lighting
