// The client's side of a session as arlightd's messages build it, without any I/O (the sans-IO
// shape of STYLE.md): receive() takes each decoded message from the server and says what it
// changed. The native client's reader thread (client_net.cpp) and the page's WebSocket
// (client/web/src/web_client.cpp) both feed it, so the server's messages are dispatched once.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "arlight/common/geo.hpp"
#include "arlight/common/sh.hpp"
#include "arlight/net/map_assembly.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// The newest lighting: live SH (from every LightingUpdate) and the newest complete map set of
// each kind. Versions increase with every change so a renderer re-uploads only what changed.
struct Lighting {
  std::uint64_t sh_version = 0, maps_version = 0, ggx_version = 0;
  std::optional<ShCoeffs> sh;
  std::shared_ptr<const ReceivedMapSet> maps;  // the thesis's Phong maps
  std::shared_ptr<const ReceivedMapSet> ggx;   // the GGX chain
  glm::vec3 dominant_direction{0.0f};  // world frame, towards the light
  glm::vec3 dominant_colour{0.0f};
  double coverage = 0;                     // fraction of the sphere measured
  double estimated = 0;                    // fraction estimated by arlightd from what was measured
  SunState sun_state = SunState::Unknown;  // what arlightd knows of the sun (with a location)
  glm::vec3 sun_direction{0.0f};           // world frame, towards it
  // The newest update's frame: its sequence, the frames the session has merged by then, and
  // the exposure x gain arlightd took it at (its estimate for a client that cannot say; 0 until
  // an update for a used frame says).
  std::uint64_t frame_sequence = 0, frames_processed = 0;
  double frame_exposure = 0;
  // How far the light may be off (PROTOCOL.md, uncertainty): the expected relative irradiance
  // error (0: not stated; wire::kLightErrorUnknown: nothing seen yet), its map in percent on
  // light_error_zones x 2 light_error_zones equal-area normals, and the view the daemon asks
  // for (world frame) with the cut it expects.
  double light_error = 0;
  int light_error_zones = 0;
  std::vector<std::uint8_t> light_error_map;
  std::optional<glm::vec3> next_view;
  double next_view_gain = 0;

  // What a LightingUpdate and a completed map set change.
  void apply(const wire::LightingUpdate& update);
  void apply(std::shared_ptr<const ReceivedMapSet> set);
};

class LightingState {
 public:
  // What a message changed (Nothing: a Progress, a Pong, a tile, a set that did not complete).
  enum class Change {
    Nothing, Welcome, Error, Update, MapSet, Calibration, ExposureAdvice, JoinToken
  };

  // The maps this connection asked for (RequestMaps): only a set of exactly these is used.
  void expect_maps(const wire::RequestMaps& request) { assembler_.expect(request); }
  void expect_any_maps() { assembler_.expect_any(); }  // a watcher's
  Change receive(wire::Message&& message);

  const Lighting& lighting() const { return lighting_; }
  const std::optional<wire::Welcome>& welcome() const { return welcome_; }
  // The server's Error: (its code's name, its message).
  const std::optional<std::pair<std::string, std::string>>& error() const { return error_; }
  // A Moved error's address (HOST:PORT of the daemon that has the session); empty otherwise.
  const std::string& moved_to() const { return moved_to_; }
  void clear_error() { error_.reset(), moved_to_.clear(); }  // before connecting again
  const std::optional<wire::LightingUpdate>& last_update() const { return last_update_; }
  const std::optional<wire::CalibrationResult>& calibration() const { return calibration_; }
  const std::optional<wire::ExposureAdvice>& exposure_advice() const { return advice_; }
  // The newest token another device may join this session with (RequestJoinToken's answer).
  const std::optional<wire::JoinToken>& join_token() const { return join_token_; }
  // The set the last Change::MapSet completed (of either kind).
  const std::shared_ptr<const ReceivedMapSet>& newest_set() const { return newest_set_; }
  std::uint64_t updates() const { return updates_; }
  std::uint64_t map_sets() const { return map_sets_; }

 private:
  MapSetAssembler assembler_;
  Lighting lighting_;
  std::shared_ptr<const ReceivedMapSet> newest_set_;
  std::optional<wire::Welcome> welcome_;
  std::optional<std::pair<std::string, std::string>> error_;
  std::string moved_to_;
  std::optional<wire::LightingUpdate> last_update_;
  std::optional<wire::CalibrationResult> calibration_;
  std::optional<wire::ExposureAdvice> advice_;
  std::optional<wire::JoinToken> join_token_;
  std::uint64_t updates_ = 0, map_sets_ = 0;
};

}  // namespace arlight::client
