// arlight-capture's two jobs over a recording: the HDR environment map the capture library
// builds from it (with a coverage picture and a JSON report), or the camera response recovered
// from a bracket. main.cpp parses the flags and calls one.
#pragma once

#include <filesystem>
#include <string>

#include "arlight/protocol/recording.hpp"

namespace arlight::capture_tool {

struct CaptureFlags {
  std::filesystem::path recording, out, json, response_dir, response_out;
  std::string response = "";  // srgb | filmic | FILE; empty: the device's curve or srgb
  std::string projection = "anglemap";
  std::string calibrate;  // robertson | debevec
  std::string fill = "estimate";
  double until_coverage = 0;       // > 0: stop once the map covers this fraction of the sphere
  std::string exposure = "known";  // known | locked | estimate
  std::string merge = "changes";  // changes | all (CaptureOptions before issue 37)
  int passes = 1;                  // the recording replayed this many times into one session
  int size = 512;
  int sh_order = 8;
  int align_every = 0;  // 0: the library's default
  int align_width = 0;  // 0: the library's default
  bool no_align = false;
  bool align_async = false;
};

// Writes --out (EXR), its .png preview and _coverage.png, and the --json report; prints a
// summary. InputError for a bad flag.
int run_capture(const CaptureFlags& o, const recording::Recording& rec);
// Recovers the response from a bracketed recording (one view at several exposures) and writes
// it to --response-out and/or files it under the device in --response-dir.
int run_calibration(const CaptureFlags& o, const recording::Recording& rec);

}  // namespace arlight::capture_tool
