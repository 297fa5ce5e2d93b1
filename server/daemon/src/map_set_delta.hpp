// What a session's client holds of its recent map sets, tile by tile (issue 36 §2): a set is
// sent as the level-0 tiles that differ from a set the client holds (MapSetComplete.base_set),
// and the client takes the rest from that one. On a narrow link most of a set is unchanged — a
// settled room's previews move a few tiles, a capture the tiles near what the camera adds — so
// the link carries what changed, not ~0.5 MB of half floats a set.
//
// A tile is unchanged when none of its texels moved by more than kTolerance of its value from
// what the client holds (not from the last set computed: small changes never add up).
// Used by one map thread at a time; clear() from any thread.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

namespace arlight::daemon {

class MapSetDeltas {
 public:
  // A texel within 1/256 of the value the client holds (a step of an 8-bit display at its
  // brightest) is not sent again.
  static constexpr float kTolerance = 1.0f / 256.0f;
  // Each map's size (width, height) in a set.
  using Shape = std::vector<std::pair<std::uint32_t, std::uint32_t>>;
  // Where a level-0 tile lies: its map, the map's size, and its rectangle.
  struct TileKey {
    std::uint16_t map = 0;
    std::uint32_t map_width = 0, map_height = 0, x = 0, y = 0, width = 0, height = 0;
    auto operator<=>(const TileKey&) const = default;
  };

  // The client's connection or its request changed: the sets it holds are unknown, and a set
  // begun before now is never a base.
  void clear();
  // The set `id` is about to stream as its change from `base` (the newest set the connection
  // has begun writing: it finishes, so the client will hold it). Returns the base it is sent
  // against: `base`, or 0 (whole) when that set is not held.
  std::uint32_t begin(std::uint32_t id, std::uint64_t base);
  // The set begun has maps of these sizes (width, height each): against a base of others (a
  // GGX chain's preview at face 128 before the full one at 256) it goes whole. Returns the
  // base it is sent against now.
  std::uint32_t shape(Shape maps);
  // A level-0 tile of the set begun, as the client decodes it (RGB rounded to half floats):
  // true when the client must be sent it. Either way the client holds it from now on: these
  // texels when sent, the base's otherwise.
  bool changed(const TileKey& key, std::shared_ptr<const std::vector<float>> texels);
  // The set streamed to its MapSetComplete: a base for later sets. A set begun before the last
  // clear() is not kept.
  void complete();
  std::size_t held() const;

 private:
  struct Held {
    Shape shape;
    std::map<TileKey, std::shared_ptr<const std::vector<float>>> tiles;
  };
  mutable std::mutex mutex_;
  std::uint64_t generation_ = 0;  // clear() calls
  std::map<std::uint32_t, Held> held_;
  struct Building {
    std::uint32_t id = 0, base = 0;
    std::uint64_t generation = 0;
    Held set;
  };
  std::optional<Building> building_;
};

}  // namespace arlight::daemon
