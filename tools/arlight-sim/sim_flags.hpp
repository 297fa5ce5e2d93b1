// arlight-sim's flags: what the simulated phone records (sim::SimOptions, set directly) and
// the rest as given (sizes, names, place and time, the reference object), checked and turned
// into options by finish_sim_options. main.cpp reads parse -> construct -> run -> report.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "arlight/reference/reference.hpp"
#include "arlight/sim/simulate.hpp"

namespace arlight::sim_tool {

struct SimFlags {
  std::string env, out, size = "640x480", trajectory = "sweep", auto_exposure = "on", marker,
                        seed = "0", y4m, location, time_text, object,
                        object_material = "0.8,0.2,80";
  std::optional<double> north_offset;
  double object_height = 0;
  int threads = 0, reference_every = 1;
  bool marker_given = false;  // --marker was on the command line (even empty: then an error)
  bool guided = false;        // --guided: follow arlightd's proposed views (guided_path)
};

void add_sim_flags(CLI::App& app, sim::SimOptions& o, SimFlags& f);

// Checks every flag (InputError naming it) and completes `o` from `f`; returns the object to
// ray trace references of (--object), if any.
std::optional<reference::ReferenceObject> finish_sim_options(const SimFlags& f, sim::SimOptions& o);

// --guided: the path of a user following arlightd's proposals in a capture of o.env at o's size,
// rate, response, noise and seed (arlight_guided's loop, with arlightd's default capture), one
// pose a frame, for SimOptions::path.
std::vector<recording::Pose> guided_path(const sim::SimOptions& o);

}  // namespace arlight::sim_tool
