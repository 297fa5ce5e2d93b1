// The page's API (web_client.hpp) bound for JavaScript: the names app.js and its modules call.
#include <emscripten/bind.h>

#include "web_client.hpp"

namespace arlight::web {

EMSCRIPTEN_BINDINGS(arlight_web) {
  emscripten::class_<WebClient>("WebClient")
      .constructor<std::string, int, int>()
      .function("hello", &WebClient::hello)
      .function("requestJoinToken", &WebClient::request_join_token)
      .function("setFov", &WebClient::set_fov)
      .function("setFocal", &WebClient::set_focal)
      .function("camera", &WebClient::camera)
      .function("setMarkerSize", &WebClient::set_marker_size)
      .function("markerSeen", &WebClient::marker_seen)
      .function("intrinsics", &WebClient::intrinsics)
      .function("frame", &WebClient::frame)
      .function("frameDue", &WebClient::frame_due)
      .function("resendFrame", &WebClient::resend_frame)
      .function("framesWaiting", &WebClient::frames_waiting)
      .function("requestMaps", &WebClient::request_maps)
      .function("requestMapsIfChanged", &WebClient::request_maps_if_changed)
      .function("receive", &WebClient::receive)
      .function("lastSequence", &WebClient::last_sequence)
      .function("cameraTexture", &WebClient::camera_texture)
      .function("yuvPlaneTexture", &WebClient::yuv_plane_texture)
      .function("convertYuv", &WebClient::convert_yuv)
      .function("render", &WebClient::render)
      .function("setShadowLights", &WebClient::set_shadow_lights)
      .function("frameTook", &WebClient::frame_took)
      .function("setMaterial", &WebClient::set_material)
      .function("setShading", &WebClient::set_shading)
      .function("setRefraction", &WebClient::set_refraction)
      .function("setColour", &WebClient::set_colour)
      .function("location", &WebClient::location)
      .function("setModel", &WebClient::set_model)
      .function("status", &WebClient::status)
      .function("objectPixel", &WebClient::object_pixel)
      .function("placedOnMarker", &WebClient::placed_on_marker)
      .function("floorPixel", &WebClient::floor_pixel)
      .function("view", &WebClient::view);
}

}  // namespace arlight::web
