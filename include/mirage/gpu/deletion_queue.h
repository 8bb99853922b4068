#pragma once
// Deferred destruction for frames in flight: a buffer or image that recorded frames may still use
// is retired with the set of frame slots that may use it, and freed once each of those slots
// reported completion (its fence signalled, or the slot was recorded again, which its owner allows
// only after the slot's previous frame completed). No device wait.
#include <cstdint>
#include <utility>
#include <vector>

#include "mirage/gpu/memory.h"

namespace mirage::gpu {

class DeletionQueue {
public:
  // `slots`: bit i set when slot i's frame may use the object; 0 frees it now.
  void retire(Buffer buffer, uint32_t slots) {
    if (slots) entries_.push_back({slots, std::move(buffer), {}});
  }
  void retire(Image image, uint32_t slots) {
    if (slots) entries_.push_back({slots, {}, std::move(image)});
  }
  // Slot `slot`'s frame completed: frees what no other pending slot may use.
  void completed(uint32_t slot) {
    for (Entry& e : entries_) e.slots &= ~(1u << slot);
    std::erase_if(entries_, [](const Entry& e) { return e.slots == 0; });
  }
  size_t pending() const { return entries_.size(); }

private:
  struct Entry {
    uint32_t slots = 0;
    Buffer buffer;
    Image image;
  };
  std::vector<Entry> entries_;
};

} // namespace mirage::gpu
