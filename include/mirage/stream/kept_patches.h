#pragma once
// What a client keeps of the patches it was told to remove (docs/stream.md, "Patch section"): a
// patch removed in frame n (the n-th Frame of a connection) stays kept through frame
// n + kKeptGeometryFrames - 1, and a block-only entry in those frames brings it back without its
// positions. The client keeps each patch's geometry (T = its patch record); the server, which has the
// scene, keeps the ids alone (T = an empty struct). Both count frames alike through this one class, so
// the server never refers to geometry the client dropped.
#include <cstdint>
#include <deque>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mirage/stream/protocol.h"

namespace mirage::stream {

template <class T> class KeptPatches {
public:
  // Starts frame `frame` (1, 2, ..., one call per frame, increasing): drops what was removed in frames
  // up to frame - kKeptGeometryFrames.
  void beginFrame(uint32_t frame) {
    frame_ = frame;
    while (!removals_.empty() && uint64_t(removals_.front().first) + kKeptGeometryFrames <= frame) {
      for (uint32_t id : removals_.front().second) {
        auto it = kept_.find(id);
        if (it != kept_.end() && it->second.first == removals_.front().first) kept_.erase(it);
      }
      removals_.pop_front();
    }
  }
  // `id` was removed in the current frame.
  void keep(uint32_t id, T value) {
    kept_[id] = {frame_, std::move(value)};
    if (removals_.empty() || removals_.back().first != frame_) removals_.push_back({frame_, {}});
    removals_.back().second.push_back(id);
  }
  // `id` comes back: its kept value, no longer kept; nullopt when it is not kept.
  std::optional<T> take(uint32_t id) {
    auto it = kept_.find(id);
    if (it == kept_.end()) return std::nullopt;
    T value = std::move(it->second.second);
    kept_.erase(it);
    return value;
  }
  bool contains(uint32_t id) const { return kept_.count(id) != 0; }
  size_t size() const { return kept_.size(); }

private:
  uint32_t frame_ = 0;
  std::unordered_map<uint32_t, std::pair<uint32_t, T>> kept_; // id -> (frame removed, value)
  // Ids removed per frame, oldest first; an id re-added (and maybe removed again) since is skipped at
  // expiry by its frame in kept_.
  std::deque<std::pair<uint32_t, std::vector<uint32_t>>> removals_;
};

} // namespace mirage::stream
