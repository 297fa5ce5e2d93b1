// A session on disk and under its lease: the checkpoint, resuming from it, releasing the session
// to another daemon and abandoning it when the lease is lost.
#include <functional>
#include <mutex>

#include "arlight/common/error.hpp"
#include "session.hpp"

namespace arlight::daemon {

void Session::checkpoint() {
  // Two at once would race: one's clean-up deletes the other's files, and manifests could
  // name an older generation after a newer one.
  std::lock_guard serial(checkpoint_mutex_);
  if (!holds_lease()) return;  // released, or taken over: another daemon may own the folder now
  SessionCheckpoint c;
  int generation;
  bool map_changed;
  {
    std::lock_guard serial(process_mutex_);  // the accumulators between two frames, not during one
    std::lock_guard lock(mutex_);
    if (!capture_) return;
    c.last_sequence = handled_sequence();
    map_changed = dirty_;
    // Frames that changed nothing still move the sequence a resumed client continues from, so
    // the manifest (not the map) is rewritten for them.
    if (!map_changed && (!accumulators_written_ || c.last_sequence == saved_sequence_)) return;
    if (map_changed) {
      c.accumulators = capture_->accumulators();
      ++checkpoint_generation_;
    }
    generation = checkpoint_generation_;
    c.id = id_, c.device_id = device_id_, c.camera = *camera_, c.response = response_name_;
    c.map_size = env_.map_size;
    c.layout = capture_->layout();
    // The frames still waiting are not in it: a resumed client sends them again.
    c.frames_received = received_ - frames_.size(), c.frames_processed = processed_;
    c.frames_dropped = dropped_, c.frames_skipped = skipped_;
    c.request = request_;
    // Every device that ever registered here, and those a checkpoint kept that have not joined
    // again since.
    std::map<std::string, ContributorCheckpoint> contributors = saved_contributors_;
    for (const auto& [device_id, device] : contributor_devices_) {
      const capture::DeviceRegistration r = capture_->registration(device);
      if (r.registered) contributors[device_id] = {device_id, r.offset, r.radiance_scale};
    }
    for (auto& [device_id, k] : contributors) c.contributors.push_back(k);
    c.coverage = capture_->coverage();
    dirty_ = false;
  }
  // Checked again right before writing: this daemon may have been stopped meanwhile and the
  // session taken over (a stop between this check and the write is the window that remains).
  if (!holds_lease()) return;
  try {
    accumulators_written_ = write_checkpoint(
        session_dir(env_, id_), c, generation,
        map_changed ? std::nullopt : accumulators_written_);
  } catch (...) {
    std::lock_guard lock(mutex_);
    dirty_ = true;  // the next checkpoint tries again
    accumulators_written_.reset();
    throw;
  }
  std::lock_guard lock(mutex_);
  saved_sequence_ = std::max(saved_sequence_, c.last_sequence);
}

void Session::release() {
  disconnect_all(false);  // the client reconnects, to whichever daemon takes it
  shutdown();
  checkpoint();  // throws: the lease is kept and the session stays usable
  {
    std::lock_guard serial(checkpoint_mutex_);
    std::lock_guard lease(lease_mutex_);
    lease_.reset();
  }
  // A client that resumed here while the last checkpoint was written holds a session that can
  // no longer be saved: it goes too, and its retry finds the session on disk.
  disconnect_all(true);
}

void Session::disconnect_all(bool watchers) {
  std::function<void()> disconnect;
  {
    std::lock_guard lock(mutex_);
    disconnect = disconnect_;
  }
  if (disconnect) disconnect();
  if (!watchers) return;
  // The session is no longer live here: its watchers watch it again where it is.
  const std::size_t watching = watchers_.disconnect_all();
  if (env_.watchers) env_.watchers->add(-double(watching));
}

bool Session::holds_lease() const {
  std::lock_guard lock(lease_mutex_);
  return lease_ && lease_->held();
}

bool Session::renew_lease() {
  std::lock_guard lock(lease_mutex_);
  return !lease_ || lease_->renew();
}

bool Session::abandon() {
  {
    std::lock_guard lock(lease_mutex_);
    if (!lease_) return false;
    lease_.reset();  // first: no checkpoint writes it from here on
  }
  disconnect_all(true);
  shutdown();
  return true;
}

std::shared_ptr<Session> Session::load(const std::string& id, const SessionEnv& env,
                                       SessionLease lease) {
  const std::optional<SessionCheckpoint> c = read_checkpoint(session_dir(env, id));
  if (!c) return nullptr;
  const std::string where = "session checkpoint of " + id;
  if (c->id != id) throw InputError(where + ": it names session " + c->id);
  auto s = std::make_shared<Session>(id, c->device_id, env, std::move(lease));
  const std::string why = s->set_camera(c->camera);
  if (!why.empty()) throw InputError(where + ": " + why);
  try {
    // A checkpoint of another layout (an angle map, before 2026-12-02; another map size) is
    // carried over into this daemon's.
    s->capture_->restore(
        capture::convert_accumulators(c->accumulators, c->capture_layout(), s->capture_->layout()));
  } catch (const std::invalid_argument& e) {
    throw InputError(where + ": " + e.what());
  }
  s->received_ = c->frames_received, s->processed_ = c->frames_processed;
  s->merged_ = c->frames_processed;  // not checkpointed: what counts is that it grows
  s->dropped_ = c->frames_dropped, s->skipped_ = c->frames_skipped;
  s->last_sequence_ = c->last_sequence;
  if (c->frames_received > 0) s->newest_sequence_ = c->last_sequence;
  s->saved_sequence_ = c->last_sequence;
  s->accumulators_written_ = c->accumulator_file;
  s->request_ = c->request;
  for (const ContributorCheckpoint& k : c->contributors) s->saved_contributors_[k.device_id] = k;
  s->checkpoint_generation_ = c->generation;
  // A checkpoint of another layout is rewritten in this daemon's at the next checkpoint.
  s->dirty_ = c->capture_layout() != s->capture_->layout();
  s->coverage_ = s->capture_->coverage();
  return s;
}

}  // namespace arlight::daemon
