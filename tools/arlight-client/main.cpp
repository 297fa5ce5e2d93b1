// arlight-client: the thin AR client. Parses its flags, builds the per-frame pipeline
// (client/app: tracking, the link to arlightd, rendering, tone mapping, compositing), runs it
// over a webcam or a recording, and reports.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "arlight/app/client_app.hpp"
#include "arlight/common/error.hpp"
#include "arlight/common/geo.hpp"
#include "arlight/common/number_list.hpp"
#include "arlight/net/session_light_files.hpp"
#include "arlight/sim_source/sim_source.hpp"
#include "flags.hpp"
#include "report.hpp"

using namespace arlight;
using namespace arlight::client_app;
using Clock = std::chrono::steady_clock;

namespace {

// What arlightd said of the sun last (with --location).
nlohmann::json sun_json(const Lighting& l) {
  nlohmann::json j = {{"state", sun_state_name(l.sun_state)}};
  if (l.sun_state != SunState::Unknown)
    j["direction"] = {l.sun_direction.x, l.sun_direction.y, l.sun_direction.z};
  return j;
}

// How far arlightd says the light may be off, and the view it asks for (PROTOCOL.md, uncertainty).
nlohmann::json light_json(const Lighting& l) {
  nlohmann::json j = {{"error", l.light_error}, {"zones", l.light_error_zones},
                      {"error_map_percent", l.light_error_map},
                      {"next_view_gain", l.next_view_gain}};
  j["next_view"] = l.next_view ? nlohmann::json{l.next_view->x, l.next_view->y, l.next_view->z}
                               : nlohmann::json(nullptr);
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("arlight-client"));
  source::register_sim_source();  // --source sim:PROBE.exr (the laboratory's simulated phone)
  CLI::App app{
      "arlight-client: tracks a marker, lights a virtual object with arlightd's "
      "lighting and composites it into the camera frames"};
  ClientFlags f;
  add_client_flags(app, f);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    // ---- construct: source, pipeline, link ----
    const std::vector<double> shininess = parse_number_list(f.maps_text, "--maps");
    std::unique_ptr<source::FrameSource> src = open_client_source(f);
    PipelineOptions po = pipeline_options(f, *src, shininess);
    render::GlContext gl =
        f.window ? render::GlContext::window(po.camera.width, po.camera.height, "arlight-client")
                 : render::GlContext::headless();
    spdlog::info("GL: {} ({})", gl.renderer(), gl.version());
    ClientObject object = load_client_object(f, po.material);
    po.model_materials = std::move(object.materials);
    FramePipeline pipeline(po, std::move(object.mesh));
    LightingLink link(link_options(f, *src, po.camera, shininess));
    link.wait_connected(std::chrono::seconds(10));
    if (f.wait_maps_s > 0 && (!shininess.empty() || link.options().ggx_face > 0))
      link.wait_for_maps(std::chrono::duration<double>(f.wait_maps_s));
    LinkChannel channel(link);

    // ---- loop ----
    RunOutput output(f.out, f.json_path);
    RunStats stats;
    cv::Mat composited;
    while (f.frames_limit <= 0 || int(stats.frames) < f.frames_limit) {
      const auto t0 = Clock::now();
      // arlightd asked for a darker frame (its exposure advice): the next one, where the
      // source can.
      if (const auto advice = link.take_exposure_advice()) src->request_exposure(*advice);
      // And the view it asks for (a guided sim: source turns there).
      const Lighting light = link.lighting();
      if (light.next_view) src->propose_view(glm::dvec3(*light.next_view));
      std::optional<source::SourceFrame> frame = src->next();
      if (!frame) break;
      const double decode_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const FrameReport r = pipeline.process(*frame, channel, composited);
      stats.add(r, decode_ms);
      if (f.window) pipeline.renderer().present(), gl.swap_buffers();
      output.add(r, composited, light);
    }

    // Frames an outage near the end kept waiting go before the report (and the Bye).
    if (!link.flush(std::chrono::seconds(10)))
      spdlog::warn("{} frames were never sent", link.stats().frames_not_sent);

    // ---- report ----
    output.finish(stats, link.stats(),
                  {{"renderer", gl.renderer()},
                   {"size", {po.camera.width, po.camera.height}},
                   {"shading", render::shading_name(po.shading)},
                   {"glass", f.glass},
                   {"occlusion", {{"state", object.occlusion_state}, {"bake_ms", object.bake_ms}}},
                   {"colour", render::colour_correction_name(po.colour)},
                   {"ior", f.ior},
                   {"sun", sun_json(channel.lighting())},
                   {"light", light_json(channel.lighting())}});
    // The room's light as engines read it, when arlightd sent its GGX chain (--ggx).
    if (const Lighting lighting = link.lighting(); !f.out.empty() && lighting.ggx && lighting.sh) {
      client::write_session_light_files(f.out, *lighting.ggx, *lighting.sh,
                                        "arlight-client, arlightd session " + link.stats().session_id);
      std::printf("light files (specular.ktx2, light.json, lighting.gltf) in %s\n", f.out.c_str());
    }
    return stats.frames > 0 ? 0 : 1;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-client: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-client: error: %s\n", e.what());
    return 1;
  }
}
