#pragma once
// A map from small integer ids (a scene's patch ids: dense, bounded by the scene) to values,
// stored as a packed array of (id, value) with an id -> position index. Lookups are one indexed
// load instead of a hash and a pointer chase, iteration walks the packed array, and erase moves the
// last entry into the hole (iteration order is insertion order until an erase). Memory: 4 bytes
// per id up to the largest id inserted, plus the entries.
#include <cstdint>
#include <utility>
#include <vector>

namespace mirage {

template <class T> class DenseIdMap {
public:
  using Entry = std::pair<uint32_t, T>;

  T* find(uint32_t id) {
    uint32_t at = positionOf(id);
    return at == kNone ? nullptr : &entries_[at].second;
  }
  const T* find(uint32_t id) const {
    uint32_t at = positionOf(id);
    return at == kNone ? nullptr : &entries_[at].second;
  }
  bool contains(uint32_t id) const { return positionOf(id) != kNone; }

  // The value of id, default-constructed when absent.
  T& operator[](uint32_t id) {
    if (T* value = find(id)) return *value;
    if (id >= position_.size()) position_.resize(size_t(id) + 1, kNone);
    position_[id] = uint32_t(entries_.size());
    entries_.emplace_back(id, T{});
    return entries_.back().second;
  }

  // Removes id if present (the last entry moves into its place); true when it was.
  bool erase(uint32_t id) {
    uint32_t at = positionOf(id);
    if (at == kNone) return false;
    eraseAt(at);
    return true;
  }
  // Removes the entry at a position of entries(); a loop erasing while it walks goes backwards.
  void eraseAt(size_t at) {
    position_[entries_[at].first] = kNone;
    if (at + 1 != entries_.size()) {
      entries_[at] = std::move(entries_.back());
      position_[entries_[at].first] = uint32_t(at);
    }
    entries_.pop_back();
  }
  void clear() { // O(entries), the index keeps its size
    for (const Entry& e : entries_) position_[e.first] = kNone;
    entries_.clear();
  }
  void reserve(size_t n) { entries_.reserve(n); }
  size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }

  std::vector<Entry>& entries() { return entries_; }
  const std::vector<Entry>& entries() const { return entries_; }
  auto begin() { return entries_.begin(); }
  auto end() { return entries_.end(); }
  auto begin() const { return entries_.begin(); }
  auto end() const { return entries_.end(); }

private:
  static constexpr uint32_t kNone = ~0u;
  uint32_t positionOf(uint32_t id) const { return id < position_.size() ? position_[id] : kNone; }

  std::vector<uint32_t> position_; // id -> its entry, kNone when absent
  std::vector<Entry> entries_;
};

} // namespace mirage
