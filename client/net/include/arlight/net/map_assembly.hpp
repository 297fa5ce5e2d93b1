// Map sets as their tiles arrive (protocol/PROTOCOL.md, item 7): level-0 tiles fill the maps,
// MapSetComplete finishes a set and makes older unfinished ones stale; a set sent as what
// changed (its base_set, issue 36 §2) takes its other tiles from the set it names. No
// networking: the native protocol client and the browser client (WebAssembly) both use it.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "arlight/common/projection.hpp"
#include "arlight/common/specular_lights.hpp"
#include "arlight/protocol/wire.hpp"

namespace arlight::client {

// A map set as it arrives: level-0 tiles fill `maps`; complete once MapSetComplete came.
// Phong: a map per shininess. Ggx: the GGX chain, maps[k] level k (cube maps, each half the
// face of the one before) at perceptual roughness[k].
struct ReceivedMapSet {
  std::uint32_t id = 0;
  wire::MapKind kind = wire::MapKind::Phong;
  std::vector<double> shininess;  // Phong
  std::vector<double> roughness;  // Ggx
  // Ggx: the small, bright lights taken out of the chain's room (split_specular_lights; the
  // chain is then the residual). Empty: the chain holds the whole room.
  std::vector<SpecularLight> lights;
  std::vector<EnvMap> maps;
  std::vector<std::size_t> texels_received;  // per map, level 0
  bool preview_received = false;             // the coarse tiles of every map
  bool complete = false;
  double server_seconds = 0;
  double coverage = 0;       // of the environment map the set was computed from
  std::uint64_t frames = 0;  // frames merged into that map
  std::uint32_t base_set = 0;  // the set its unchanged tiles came from (0: sent whole)
};

class MapSetAssembler {
 public:
  // The newest complete sets kept as bases for sets sent as what changed: the server sends a
  // change against the newest set the connection has begun writing, which is at most the
  // second newest the client completed by then.
  static constexpr std::size_t kBases = 2;

  // What this connection asked for (RequestMaps). Only a set of exactly these maps is used
  // (Phong: the shininess list; Ggx: a chain of as many levels, each level's face half the one
  // before, roughness rising), and none before a request: a resumed session's set still in
  // flight for an earlier connection's request reaches the new connection too (a client that
  // asked for no maps was then drawn with them).
  void expect(const wire::RequestMaps& request);
  // A watcher (Hello's watch_session) asks for nothing: it takes whatever whole sets the
  // session streams, Phong or GGX, as long as each is consistent in itself.
  void expect_any();
  // A tile whose size disagrees with its set's first tiles, or whose data does not decode, is
  // dropped (the set then never completes its texel count).
  void add_tile(const wire::MapTile& tile);
  // The completed set, or nullptr unless every one of its `done.maps` maps arrived whole (a set
  // begun on an earlier connection of a resumed session, or with a dropped tile, is not used).
  // A set sent as its change from `done.base_set` is whole when that set is one this client
  // holds and every one of the `done.tiles` tiles sent arrived.
  std::shared_ptr<const ReceivedMapSet> complete(const wire::MapSetComplete& done);

 private:
  struct Building {
    ReceivedMapSet set;
    std::vector<std::vector<bool>> received;  // per map, per level-0 texel
    std::uint32_t tiles = 0;                  // level-0 tiles taken
  };
  // The set `done` sent as its change from a held set, or nullopt.
  std::optional<ReceivedMapSet> apply_change(Building& building, const wire::MapSetComplete& done) const;
  bool as_expected(const ReceivedMapSet& set) const;

  std::map<std::uint32_t, Building> building_;
  std::deque<std::shared_ptr<const ReceivedMapSet>> bases_;  // newest last
  bool requested_ = false;
  bool any_ = false;  // expect_any()
  wire::MapKind kind_ = wire::MapKind::Phong;
  std::vector<float> expected_;  // Phong: as the wire carries them
  std::size_t levels_ = 0;       // Ggx
  std::size_t lights_ = 0;       // Ggx: the most lights the request took out of the chain
};

}  // namespace arlight::client
