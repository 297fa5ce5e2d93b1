// Map sets as their tiles arrive (protocol/PROTOCOL.md, item 7): level-0 tiles fill the maps,
// MapSetComplete finishes a set and makes older unfinished ones stale. No networking: the
// native protocol client and the browser client (WebAssembly) both use it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// A map set as it arrives: level-0 tiles fill `maps`; complete once MapSetComplete came.
struct ReceivedMapSet {
  std::uint32_t id = 0;
  std::vector<double> shininess;
  std::vector<EnvMap> maps;
  std::vector<std::size_t> texels_received;  // per map, level 0
  bool preview_received = false;             // the coarse tiles of every map
  bool complete = false;
  double server_seconds = 0;
  double coverage = 0;       // of the environment map the set was computed from
  std::uint64_t frames = 0;  // frames merged into that map
};

class MapSetAssembler {
 public:
  // The shininess list this connection asked for (RequestMaps). Only a set of exactly these maps
  // is used, and none before a request: a resumed session's set still in flight for an earlier
  // connection's request reaches the new connection too (a client that asked for no maps was
  // then drawn with them).
  void expect(const std::vector<double>& shininess);
  // A tile whose size disagrees with its set's first tiles, or whose data does not decode, is
  // dropped (the set then never completes its texel count).
  void add_tile(const wire::MapTile& tile);
  // The completed set, or nullopt unless every one of its `done.maps` maps arrived whole (a set
  // begun on an earlier connection of a resumed session, or with a dropped tile, is not used).
  std::optional<ReceivedMapSet> complete(const wire::MapSetComplete& done);

 private:
  std::map<std::uint32_t, ReceivedMapSet> building_;
  std::vector<float> expected_;  // as the wire carries them
};

}  // namespace arlight::client
