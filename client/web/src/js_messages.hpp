// The protocol's bytes between JavaScript and the codec, for both WebAssembly modules (the
// page's, web_client.cpp, and the light core, light_client.cpp): a message out as a Uint8Array,
// one from the WebSocket decoded or refused with the codec's reason.
#pragma once

#include <emscripten/bind.h>
#include <emscripten/val.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "arlight/protocol/wire.hpp"

namespace arlight::web {

// A typed array of `type` ("Uint8Array", "Float32Array", ...) holding a copy of `values`: a view
// into the module's memory would change under the next call.
template <class T>
emscripten::val typed_array(const char* type, const std::vector<T>& values) {
  return emscripten::val::global(type).new_(
      emscripten::typed_memory_view(values.size(), values.data()));
}

inline emscripten::val bytes_to_js(const std::vector<std::uint8_t>& bytes) {
  return typed_array("Uint8Array", bytes);
}

// The message in `bytes` (a Uint8Array from the WebSocket), or nullopt with `error` saying why
// the codec refused it.
inline std::optional<wire::Message> message_from_js(const emscripten::val& bytes,
                                                    std::string& error) {
  const std::vector<std::uint8_t> envelope =
      emscripten::convertJSArrayToNumberVector<std::uint8_t>(bytes);
  try {
    return wire::decode(envelope);
  } catch (const wire::DecodeError& e) {
    error = std::string("bad message from the server: ") + e.what();
    return std::nullopt;
  }
}

}  // namespace arlight::web
