// arlight-client's flags and what they build: the frame source, the pipeline's options, the
// object and the link to arlightd. main.cpp reads parse -> construct -> loop -> report over them.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arlight/app/client_app.hpp"
#include "arlight/source/source.hpp"

namespace arlight::client_app {

struct ClientFlags {
  std::string server, token, source_spec,
      model = "sphere", material_text = "0.8,0.2,80", marker_text = "0,0.2", out, json_path, device,
      resume, tone = "camera", response = "srgb", maps_text = "1,10,20,40,80,160,320,1280",
      intrinsics_file, normal_map, light_map, shadow = "on", size = "640x480", shading = "maps",
      location, time_text, glass = "off", pose = "track", occlusion = "baked";
  std::optional<double> north_offset;
  bool window = false, realtime = false, guided = false;
  int frames_limit = 0, map_size = 128, shadow_lights = 16, ggx_face = -1, ggx_lights = 0;
  double object_height = 0, wait_maps_s = 0, ior = 1.5, fps = 30, target_fps = 30;
  client::TlsOptions tls;
};

void add_client_flags(CLI::App& app, ClientFlags& f);

// The frame source the flags name (--source, --size, --fps, --frames, --realtime, --intrinsics).
std::unique_ptr<source::FrameSource> open_client_source(const ClientFlags& f);

// The pipeline's options for frames of `src`, which requests maps of `shininess`: marker,
// material (or glass), shadows, tone, shading, response, and the true poses of a simulated
// recording (--pose truth draws at them). InputError for a bad flag.
PipelineOptions pipeline_options(const ClientFlags& f, const source::FrameSource& src,
                                 const std::vector<double>& shininess);

// The object to draw (--model), with its occlusion baked or cleared (--occlusion) and its
// textures loaded (--normal-map, --light-map; needs a GL context).
struct ClientObject {
  render::Mesh mesh;
  std::vector<render::Material> materials;  // --material model: the glTF's
  std::string occlusion_state = "none";  // file, cached, baked or none
  double bake_ms = 0;
};
ClientObject load_client_object(const ClientFlags& f, render::Material& material);

// The link to arlightd: endpoint, token, TLS, device, the session to resume, the camera, the
// maps to request, exposure advice if the source can follow it, and where and when (--location,
// --time, --north-offset; a replay of a recording that says where it was made tells that).
LinkOptions link_options(const ClientFlags& f, source::FrameSource& src,
                         const CameraIntrinsics& camera, const std::vector<double>& shininess);

}  // namespace arlight::client_app
