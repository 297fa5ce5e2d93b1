#include "watchers.hpp"

#include <variant>

namespace arlight::daemon {

namespace {

// A tile's envelope again with its data in `coding` (half floats survive the round trip
// exactly); nullptr when it cannot be read back (it was encoded here: never).
EncodedMessage recode_tile(const EncodedMessage& bytes, wire::TileCoding coding) {
  wire::Message m = wire::decode(*bytes);
  auto* tile = std::get_if<wire::MapTile>(&m);
  if (!tile) return nullptr;
  std::string why;
  const std::size_t pixels = std::size_t(tile->width) * tile->height;
  const auto rgb = wire::decode_half_rgb(tile->data, pixels, tile->coding, why);
  if (!rgb) return nullptr;
  tile->data = wire::encode_half_rgb(rgb->data(), pixels, coding);
  tile->coding = coding;
  return std::make_shared<const std::vector<std::uint8_t>>(wire::encode(*tile));
}

}  // namespace

std::uint64_t WatcherSet::add(Watcher watcher, const EncodedMessage& first) {
  std::lock_guard lock(mutex_);
  if (watchers_.size() >= limit_) return 0;
  const std::uint64_t id = ++next_id_;
  Entry& e = watchers_.emplace(id, Entry{std::move(watcher)}).first->second;
  e.watcher.send(first, std::nullopt);
  e.owes_update = bool(latest_update_) && e.watcher.updates;
  for (std::size_t k = 0; k < latest_sets_.size(); ++k) e.owes_set[k] = !latest_sets_[k].empty();
  catch_up(e);
  return id;
}

bool WatcherSet::remove(std::uint64_t id) {
  std::lock_guard lock(mutex_);
  return watchers_.erase(id) > 0;
}

std::size_t WatcherSet::size() const {
  std::lock_guard lock(mutex_);
  return watchers_.size();
}

void WatcherSet::send_held(Entry& e, Held& h) {
  if (!h.tile_coding || *h.tile_coding == e.watcher.coding) return e.watcher.send(h.bytes, h.bulk);
  if (!h.recoded) h.recoded = recode_tile(h.bytes, e.watcher.coding);
  if (h.recoded) e.watcher.send(h.recoded, h.bulk);
}

// Never in the middle of a set it is receiving: the newest complete set would interleave its
// tiles with the newer set's.
void WatcherSet::catch_up(Entry& e) {
  if (behind(e)) return;
  if (e.owes_update) {
    e.watcher.send(latest_update_, std::nullopt);
    e.owes_update = false;
  }
  if (building_id_ != 0 && e.in_set == building_id_) return;
  for (std::size_t k = 0; k < latest_sets_.size(); ++k)
    if (e.owes_set[k]) {
      for (Held& h : latest_sets_[k]) send_held(e, h);
      e.owes_set[k] = false;
    }
}

void WatcherSet::publish(const wire::Message& message, const EncodedMessage& bytes,
                         std::optional<BulkGroup> bulk) {
  std::uint32_t set = 0;
  std::optional<wire::TileCoding> tile_coding;
  if (const auto* p = std::get_if<wire::Progress>(&message)) set = p->map_set;
  const auto* tile = std::get_if<wire::MapTile>(&message);
  if (tile) set = tile->map_set, tile_coding = tile->coding;
  const auto* complete = std::get_if<wire::MapSetComplete>(&message);
  if (complete) set = complete->map_set;
  const bool update = std::holds_alternative<wire::LightingUpdate>(message);
  if (!update && !set) return;  // the capturing client's own

  std::lock_guard lock(mutex_);
  if (update) {
    latest_update_ = bytes;
    for (auto& [id, e] : watchers_) {
      if (!e.watcher.updates) continue;
      e.owes_update = true;
      catch_up(e);
    }
    return;
  }
  if (set != building_id_) {  // a new set begins (the last one completed or was stopped)
    building_.clear();
    building_id_ = set;
    building_kind_ = wire::MapKind::Phong;
    for (auto& [id, e] : watchers_)
      e.in_set = behind(e) ? 0 : set;  // one behind skips the set and is owed it at the end
  }
  if (tile) building_kind_ = tile->kind;
  Held held{bytes, tile_coding, nullptr, bulk};
  for (auto& [id, e] : watchers_)
    if (e.in_set == set) send_held(e, held);
  if (!std::holds_alternative<wire::Progress>(message)) building_.push_back(std::move(held));
  if (!complete) return;
  const std::size_t kind = building_kind_ == wire::MapKind::Ggx ? 1 : 0;
  latest_sets_[kind] = std::move(building_);
  building_.clear();
  building_id_ = 0;
  for (auto& [id, e] : watchers_) {
    e.owes_set[kind] = e.in_set != set;
    e.in_set = 0;
    catch_up(e);
  }
}

void WatcherSet::drained(std::uint64_t id) {
  std::lock_guard lock(mutex_);
  const auto it = watchers_.find(id);
  if (it == watchers_.end()) return;
  const Entry& e = it->second;
  if (e.owes_update || e.owes_set[0] || e.owes_set[1]) catch_up(it->second);
}

std::size_t WatcherSet::disconnect_all() {
  std::map<std::uint64_t, Entry> gone;
  {
    std::lock_guard lock(mutex_);
    gone.swap(watchers_);
  }
  std::size_t watching = 0;
  for (auto& [id, e] : gone) {
    if (e.watcher.disconnect) e.watcher.disconnect();
    watching += e.watcher.updates;
  }
  return watching;
}

}  // namespace arlight::daemon
