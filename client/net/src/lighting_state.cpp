#include "arlight/net/lighting_state.hpp"

namespace arlight::client {

void Lighting::apply(const wire::LightingUpdate& u) {
  sh = u.sh;
  ++sh_version;
  dominant_direction = u.dominant_direction;
  dominant_colour = u.dominant_colour;
  coverage = u.coverage;
  estimated = u.estimated;
  sun_state = u.sun_state;
  sun_direction = u.sun_direction;
  frame_sequence = u.frame_sequence;
  frames_processed = u.frames_processed;
  if (u.frame_exposure > 0.0) frame_exposure = u.frame_exposure;  // 0: a frame not used
  light_error = u.light_error;
  light_error_zones = u.light_error_zones;
  light_error_map = u.light_error_map;
  next_view = u.next_view;
  next_view_gain = u.next_view_gain;
}

void Lighting::apply(std::shared_ptr<const ReceivedMapSet> set) {
  if (set->kind == wire::MapKind::Ggx) {
    ggx = std::move(set);
    ++ggx_version;
  } else {
    maps = std::move(set);
    ++maps_version;
  }
}

LightingState::Change LightingState::receive(wire::Message&& message) {
  if (auto* w = std::get_if<wire::Welcome>(&message)) {
    welcome_ = std::move(*w);
    return Change::Welcome;
  }
  if (auto* e = std::get_if<wire::Error>(&message)) {
    error_ = {wire::error_code_name(e->code), e->message};
    moved_to_ = e->address;
    return Change::Error;
  }
  if (auto* u = std::get_if<wire::LightingUpdate>(&message)) {
    lighting_.apply(*u);
    last_update_ = std::move(*u);
    ++updates_;
    return Change::Update;
  }
  if (auto* t = std::get_if<wire::MapTile>(&message)) {
    assembler_.add_tile(*t);
    return Change::Nothing;
  }
  if (auto* c = std::get_if<wire::MapSetComplete>(&message)) {
    auto set = assembler_.complete(*c);
    if (!set) return Change::Nothing;
    newest_set_ = std::move(set);
    lighting_.apply(newest_set_);
    ++map_sets_;
    return Change::MapSet;
  }
  if (auto* r = std::get_if<wire::CalibrationResult>(&message)) {
    calibration_ = std::move(*r);
    return Change::Calibration;
  }
  if (auto* a = std::get_if<wire::ExposureAdvice>(&message)) {
    advice_ = *a;
    return Change::ExposureAdvice;
  }
  if (auto* j = std::get_if<wire::JoinToken>(&message)) {
    join_token_ = std::move(*j);
    return Change::JoinToken;
  }
  return Change::Nothing;  // Progress, Pong; client-to-server messages are ignored
}

}  // namespace arlight::client
