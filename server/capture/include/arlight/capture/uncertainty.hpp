// How far the light may be off, per normal direction, given what the capture has not seen yet,
// and the view that would cut that most (issue 48: the daemon knows what it does not know and
// asks for the view that tells it).
//
// The fill (arlight/capture/fill.hpp) gives one plausible completion of the unseen part. Around
// it lie a dark and a bright completion: each unseen cell's radiance divided by, or multiplied
// by, a factor that grows with its angular distance from the nearest well-seen cell (next to
// what was seen the room is mostly like it; half the sphere away, an unseen lamp or sky may be
// `bright_factor` times what the fill guessed, straight up `up_bright_factor` times (a room's
// light comes from above: the sky, the sun, the ceiling's lamps), an unseen wall `dark_factor`
// times darker; the spread of the rooms in bench/RESULTS.md "Issue 16"). For a normal n, with
//   S = the measured part of its cosine lobe, U = the fill's, U_lo and U_hi = the dark and
//   bright completions' (the lobe's integrals on the coarse grid),
// the irradiance error relative to the truth (thesis eq. 6.1's per-texel term) is at most
//   u(n) = max((U_hi - U) / (S + U_hi), (U - U_lo) / (S + U_lo)) + measured_error * S / (S + U)
// when the truth lies between the two completions; measured_error covers what the measured part
// itself is off (noise, exposure, alignment: the 2-3 % of a finished sweep). The defaults come
// from arlight-bench-fill on twelve probes (bench/RESULTS.md "Issue 48"): 6x brighter bracketed
// 92 / 81 / 74 % of the directions at 20 / 40 / 60 % coverage, 14x (with the spread full at 45
// degrees) 98 / 91 / 87 % at a median 2.7-2.9x the real error, 8x rising to 40x straight up
// 99 / 93 / 90 % at 2.8-3.1x; the up prior also turns the guide to the lights first (the mean
// error 5 s into a guided capture of four rooms: 40 % with 14x all round, 10 % with it).
//
// The next view: seeing an unseen cell removes its part of every u(n); to first order the mean
// of u over the normals falls by the sum, over the unseen cells inside the camera's view cone,
// of each cell's share of the bounds. The proposal is the cell direction whose cone cuts the
// mean most, with the share of the sphere still unseen in it added (what no bound sees: a hole
// between views may hide a lamp the fill cannot guess), counted down by how far the camera has
// to turn to it (a user turns to a near view sooner; views behind them cost a turn).
//
// A LightUncertainty is a value computed from one fit (~0.3 ms); const members are thread-safe.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <vector>

#include "arlight/capture/fill.hpp"

namespace arlight::capture {

struct UncertaintyOptions {
  double measured_error = 0.045;  // relative error of the measured part of a lobe
  double bright_factor = 8.0;     // how much brighter than the fill an unseen cell far away may be
  // ... straight up (the sky, the ceiling's lamps: where a room's light comes from); in between,
  // geometric in the sine of the elevation from bright_factor at and below the horizon.
  double up_bright_factor = 40.0;
  double dark_factor = 4.0;      // and how much darker
  double reach_deg = 45.0;       // the angular distance at which the spread is full
  double near_spread = 0.2;      // share of the full spread (in log) next to a well-seen cell
  // The bright completion starts from at least this share of the mean measured luminance (the
  // fill may hold a near-black cell where an unseen lamp is).
  double bright_floor = 0.1;
  double clipped_factor = 2.0;  // a clipped light's bright completion, times its floor
  int zones = 16;      // the grid the bounds are summed on: zones x 2 zones equal-area cells
  int map_zones = 8;   // the stated map of u: map_zones x 2 map_zones equal-area normals
  double view_half_angle_deg = 25.0;  // the camera's view, as a cone (60 x 47 degrees)
  double travel_deg = 90.0;           // a view this far from the camera's counts half
};

// A seen texel whose light clipping hid (CaptureSession's clip floor, issue 16 §4): the map
// holds `measured` there (luminance), the light is at least `floor`. The bounds count it as
// unseen: the dark completion is what the map holds, the bright one the whole texel at its floor
// times clipped_factor (a light is at least its floor where it clipped; a texel may hold a
// lamp smaller than itself, so the map's mean there stays below the floor even when every frame
// has been taken); seeing it unclipped (a darker frame, the exposure advice's) is a view worth
// asking for.
struct ClippedTexel {
  glm::dvec3 direction{0.0, 1.0, 0.0};
  double solid_angle = 0, measured = 0, floor = 0;
};

struct ProposedView {
  glm::dvec3 direction{0.0, 0.0, -1.0};  // unit, world frame: where to point the camera
  double gain = 0.0;                     // the expected cut of the mean error (relative)
};

class LightUncertainty {
 public:
  // Nothing seen: every normal's error unknown (u = max_error), no view to propose.
  LightUncertainty();
  // From the fill's last fit. Throws std::invalid_argument for options out of range: factors
  // >= 1 (up_bright_factor >= bright_factor), reach > 0, near_spread in [0, 1], zones in
  // [2, 64], map_zones in [1, 32], the view's half angle in (0, 90], travel > 0, measured_error
  // and bright_floor >= 0.
  explicit LightUncertainty(const UnseenEstimator::Cells& cells,
                            const UncertaintyOptions& options = {},
                            std::span<const ClippedTexel> clipped = {});

  static constexpr double kMaxError = 10.0;  // u is capped here (1000 %)

  // u(n) for a unit normal: the bound on |E - E_true| / E_true of the irradiance towards n.
  double at(const glm::dvec3& normal) const;
  // The mean of u over the sphere of normals (the map's cells have equal solid angle): the
  // expected irradiance error a client states ("good to +-N %").
  double mean() const { return mean_; }
  // u on map_zones x 2 map_zones equal-area cells, row-major from the bottom zone (y = -1):
  // zone z spans y in [2z/Z - 1, 2(z+1)/Z - 1], sector a the azimuth atan2(x, -z) + pi in
  // [2 pi a / A, 2 pi (a+1) / A].
  const std::vector<float>& map() const { return map_; }
  int map_zones() const { return map_zones_; }
  // The expected cut of mean() from seeing the view cone around `view` (unit): a proposal's
  // gain. The clipped lights of cells inside the cone of a `visited` view do not count: that
  // view has been held and they still clip (only a darker frame tells them, the exposure
  // advice's job); their open unseen parts still do.
  double gain(const glm::dvec3& view, std::span<const glm::dvec3> visited = {}) const;
  // What a view is worth asking for: its gain plus the share of the sphere still unseen (not
  // clipped) in its cone.
  double worth(const glm::dvec3& view, std::span<const glm::dvec3> visited = {}) const;
  // The view worth most, counted down by the turn from a camera looking along `current` (unit;
  // none: no preference); std::nullopt when none is worth 0.1 % (everything seen, or a few
  // texels left) or nothing was seen. Views within half the view's half angle of a `visited`
  // direction are not proposed (ViewGuide), and their clipped lights count for none. The
  // proposal's gain is its gain().
  std::optional<ProposedView> next_view(std::optional<glm::dvec3> current,
                                        std::span<const glm::dvec3> visited = {}) const;

 private:
  struct Bounds {
    double seen = 0, fill = 0, dark = 0, bright = 0;  // S, U, U_lo, U_hi of a lobe
  };
  Bounds lobe(const glm::dvec3& normal) const;
  double error_of(const Bounds& b) const;

  UncertaintyOptions options_;
  bool known_ = false;
  // Per cell of the grid: mean direction, measured S_c, fill U_c, dark and bright (luminance x sr).
  std::vector<glm::dvec3> direction_;
  std::vector<double> seen_, fill_, dark_, bright_, unseen_omega_;
  std::vector<double> open_omega_;  // the unseen solid angle less the clipped texels'
  // Per cell: the first-order cut of mean() from seeing its open unseen part, and from
  // measuring its clipped lights.
  std::vector<double> cut_open_, cut_clipped_;
  std::vector<float> map_;
  int map_zones_ = 0;
  double mean_ = kMaxError;
};

// The proposals of one capture over time (arlightd's per session, the guided simulations'): the
// uncertainty's next view, except where the camera has already held a proposed view for
// `dwell_s` — what that view can tell (a light the darkest frame still clips, a part the fill
// keeps unsure of) it has told, so the guide moves on instead of asking for it again; such a
// view may be asked for again `forget_s` later. A proposal stands until it is held, or a new
// view would gain `switch_ratio` times as much (a proposal of a hole, which gains next to
// nothing, gives way to any view that gains): a user cannot follow a guide that changes its mind
// every frame.
class ViewGuide {
 public:
  struct Options {
    // A proposal held this long is done (0.3 s: ~9 frames, past a refit of the fill; on four
    // rooms at 20 fps, 1 s left hall.exr 45 % off after 15 s, 0.4 s 24 %, 0.2 s 14 %).
    double dwell_s = 0.3;
    double forget_s = 10.0;    // and may come back after this
    double held_deg = 12.0;    // the camera holds a proposal within this angle of it
    double switch_ratio = 1.5;  // a new proposal must gain this many times the standing one's
  };
  ViewGuide() : ViewGuide(Options{}) {}
  explicit ViewGuide(Options options);
  // After a frame taken at `time` (seconds, increasing) by a camera looking along `looking`
  // (unit, world frame): the view to ask for now.
  std::optional<ProposedView> next(const LightUncertainty& uncertainty, const glm::dvec3& looking,
                                   double time);

 private:
  Options options_;
  std::optional<glm::dvec3> proposal_;
  double held_since_ = -1.0;  // when the camera came to the proposal (-1: it is not there)
  std::vector<glm::dvec3> visited_;
  std::vector<double> visited_at_;
};

}  // namespace arlight::capture
