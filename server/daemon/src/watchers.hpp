// A session's watchers (Hello's watch_session, protocol/PROTOCOL.md item 1): other devices — a
// desktop's three.js page, a second phone — that get the session's LightingUpdates and map sets,
// send no frames and never change the session. The session hands every message it sends its
// capturing client to publish(); a watcher gets it unless it is behind (more than kBehindBytes
// wait on its connection). A watcher behind skips updates and whole map sets, and once it has
// caught up gets the newest update and the newest complete set: never a queue of stale ones.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "arlight/protocol/wire.hpp"

namespace arlight::daemon {

using EncodedMessage = std::shared_ptr<const std::vector<std::uint8_t>>;

// A map set's message on its way to a client: bulk data of the set `group` in `lane` (its kind),
// which a connection writes after any other message and drops unwritten when a newer set of the
// lane comes (MessageStream::send_bulk). Other messages have none.
struct BulkGroup {
  std::uint32_t lane = 0;
  std::uint64_t group = 0;
};
// Sends one encoded message to a connection; thread-safe.
using Sink = std::function<void(EncodedMessage, std::optional<BulkGroup>)>;

class WatcherSet {
 public:
  struct Watcher {
    Sink send;  // onto its connection's queue
    std::function<std::size_t()> backlog;      // bytes waiting on its connection
    wire::TileCoding coding = wire::TileCoding::ZstdHalf;  // the tiles its Hello accepts
    std::function<void()> disconnect;          // closes its connection
    // A contributor (Hello's join_session, issue 49 §1) takes the map sets only: its updates
    // are its own frames' (the session's numbering is not its).
    bool updates = true;
  };
  // More than this waiting on a watcher's connection (a 256-a-face GGX chain is ~3 MiB of half
  // floats): it is behind, and skips what comes until it has caught up.
  static constexpr std::size_t kBehindBytes = 4u << 20;

  explicit WatcherSet(std::size_t limit) : limit_(limit) {}

  // The new watcher's number, or 0 when the session has its limit. Admitted, it gets `first`
  // (its Welcome), the newest update and the newest complete map set of each kind at once, and
  // every set that starts after it joined.
  std::uint64_t add(Watcher watcher, const EncodedMessage& first);
  bool remove(std::uint64_t id);  // false when it was not there (gone already)
  std::size_t size() const;
  std::size_t limit() const { return limit_; }

  // A message the session sent its client, encoded as `bytes`. LightingUpdate, Progress,
  // MapTile and MapSetComplete go to the watchers; the rest (ExposureAdvice, Error,
  // CalibrationResult) are the capturing client's own.
  void publish(const wire::Message& message, const EncodedMessage& bytes,
               std::optional<BulkGroup> bulk = std::nullopt);
  // A watcher's connection wrote a message: it gets what it skipped once it has caught up.
  void drained(std::uint64_t id);
  // The session ended here (closed, handed over): every watcher's connection closes (the
  // contributors' too). Returns how many watchers there were (not counting contributors).
  std::size_t disconnect_all();

 private:
  // A message of a map set, kept for the watchers that join or catch up later; its tiles in
  // the other coding made when a watcher needs them.
  struct Held {
    EncodedMessage bytes;
    std::optional<wire::TileCoding> tile_coding;  // a MapTile's
    EncodedMessage recoded;                       // in the other coding
    std::optional<BulkGroup> bulk;
  };
  struct Entry {
    Watcher watcher;
    std::uint32_t in_set = 0;  // the set it is receiving from its start (0: none)
    bool owes_update = false;
    std::array<bool, 2> owes_set{};  // the newest complete set of each kind (Phong, GGX)
  };
  bool behind(const Entry& e) const { return e.watcher.backlog() > kBehindBytes; }
  void send_held(Entry& e, Held& h);
  void catch_up(Entry& e);  // with mutex_ held

  mutable std::mutex mutex_;  // everything below
  std::size_t limit_;
  std::uint64_t next_id_ = 0;
  std::map<std::uint64_t, Entry> watchers_;
  EncodedMessage latest_update_;
  // The newest complete set of each kind (wire::MapKind: Phong, GGX), its MapSetComplete last: a
  // session may stream both (its client's Phong maps, its watchers' chain).
  std::array<std::vector<Held>, 2> latest_sets_;
  std::vector<Held> building_;  // the set being streamed
  std::uint32_t building_id_ = 0;
  wire::MapKind building_kind_ = wire::MapKind::Phong;
};

}  // namespace arlight::daemon
