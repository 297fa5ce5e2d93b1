// arlight-replay: streams a recording to arlightd as a phone would and writes what came back
// (the last live SH, the map set as EXR files, a JSON summary).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "arlight/common/error.hpp"
#include "arlight/common/number_list.hpp"
#include "arlight/flags/connection_flags.hpp"
#include "arlight/net/client_messages.hpp"
#include "arlight/net/client_net.hpp"
#include "arlight/protocol/recording.hpp"
#include "arlight/protocol/wire.hpp"
#include "replay_report.hpp"

namespace fs = std::filesystem;
using namespace arlight;

int main(int argc, char** argv) {
  CLI::App app{"arlight-replay: stream a recording to arlightd and save what it sends back"};
  std::string server, token, recording_dir, device, resume, out = "out/replay", json_path;
  std::string maps = "1,10,20,40,80,160,320,1280";
  int map_size = 128, ggx_face = 0;
  double timeout_s = 120;
  bool realtime = false;
  app.add_option("--server", server, "arlightd HOST:PORT")->required();
  app.add_option("--token", token, "this device's token")->required();
  app.add_option("--recording", recording_dir, "recording folder")->required();
  app.add_option("--device", device, "device id (default: the recording's)");
  app.add_flag("--realtime", realtime,
               "send at the recording's pace (default: each frame after the previous one's "
               "update, so every frame is processed)");
  app.add_option("--maps", maps, "shininess list to request; '' requests none")
      ->capture_default_str();
  app.add_option("--map-size", map_size, "size of the requested maps")->capture_default_str();
  app.add_option("--ggx", ggx_face,
                 "request the GGX chain from this face (a power of two) down to 16 instead of "
                 "--maps, and write it with the SH and primary light as the light files "
                 "(specular.ktx2, light.json, lighting.gltf) in --out");
  app.add_option("--resume", resume, "continue this session id");
  app.add_option("--out", out, "folder for replay.json and maps/")->capture_default_str();
  app.add_option("--json", json_path, "also write the summary here");
  tools::ConnectionFlags connection;
  connection.add_to(app);
  app.add_option("--timeout", timeout_s, "seconds to wait for updates and the map set")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    std::string host;
    std::uint16_t port = 0;
    wire::parse_endpoint(server, host, port);
    const recording::Recording rec = recording::read_recording(recording_dir);
    const std::vector<double> shininess = parse_number_list(maps, "--maps");
    const std::chrono::milliseconds timeout(std::int64_t(timeout_s * 1000));

    client::Client c;
    connection.apply(c);
    const client::Welcome w = c.connect(host, port, device.empty() ? rec.device_id : device, token,
                                        "arlight-replay", resume);
    std::printf("session %s%s\n", w.session_id.c_str(), w.resumed ? " (resumed)" : "");
    c.send_intrinsics(rec.camera);
    // A recording that says where and when it was made (RECORDING.md "place"): arlightd can
    // place the sun (dissertation §5.3.3).
    if (rec.place && wire::has_capability(w.capabilities, wire::kServerCapabilityLocation)) {
      c.send_location(client::make_location(
          rec.place->where,
          rec.place->utc_seconds + (rec.frames.empty() ? 0.0 : rec.frames.front().timestamp),
          rec.place->north_offset_deg));
      std::printf("told arlightd where and when the recording was made (%.5f, %.5f)\n",
                  rec.place->where.latitude_deg, rec.place->where.longitude_deg);
    }
    const bool ggx = ggx_face > 0, maps_wanted = ggx || !shininess.empty();
    if (ggx)
      c.request_maps(client::ggx_request(ggx_face));
    else if (!shininess.empty())
      c.request_maps(shininess, map_size);

    std::size_t sent = 0;
    std::uint64_t last_sequence = 0;
    recording::FrameReader reader(rec, realtime, [](std::size_t i, const std::string& why) {
      std::fprintf(stderr, "frame %zu not sent: %s\n", i, why.c_str());
    });
    while (const auto item = reader.next()) {
      const std::size_t i = item->index;
      // After the frames the session has (a resume): a frame at or below it would be a duplicate.
      const std::uint64_t seq = w.last_sequence + i + 1;
      c.send_jpeg_frame(seq, *item->frame, rec.camera.width, rec.camera.height, item->jpeg);
      ++sent;
      last_sequence = seq;
      if (!realtime && !c.wait_for(
                           [&] {
                             const auto u = c.last_update();
                             return (u && u->frame_sequence >= seq) || c.server_error();
                           },
                           timeout))
        throw std::runtime_error("no update for frame " + std::to_string(i));
      if (const auto e = c.server_error()) throw client::ClientError(e->first, e->second);
    }
    // The last frame's update, then a map set computed from the map with every frame in it
    // (the daemon computes one when frames stop arriving).
    c.wait_for(
        [&] {
          const auto u = c.last_update();
          return u && u->frame_sequence >= last_sequence;
        },
        timeout);
    const std::uint64_t processed = c.last_update() ? c.last_update()->frames_processed : 0;
    if (maps_wanted && !c.wait_for(
                           [&] {
                             const auto m = ggx ? c.last_complete_ggx() : c.last_complete_maps();
                             return (m && m->frames >= processed) || c.server_error();
                           },
                           timeout))
      std::fprintf(stderr, "arlight-replay: no map set with all frames within the timeout\n");
    if (const auto e = c.server_error()) throw client::ClientError(e->first, e->second);

    replay_tool::write_replay_results(out, json_path, w, c, sent);
    const auto u = c.last_update();
    c.bye();
    std::printf("%zu frames sent, %llu processed, %llu map sets; results in %s\n", sent,
                static_cast<unsigned long long>(u ? u->frames_processed : 0),
                static_cast<unsigned long long>(c.map_sets_completed()), out.c_str());
    return 0;
  } catch (const InputError& e) {
    std::fprintf(stderr, "arlight-replay: bad input: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "arlight-replay: %s\n", e.what());
    return 1;
  }
}
