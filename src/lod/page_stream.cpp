// The background page reader of paged cluster DAGs (page_stream.h).
#include "mirage/lod/page_stream.h"

#include <algorithm>

namespace mirage::lod {

PageStream::PageStream(const asset::AssetReader& reader, std::span<const PagedMesh> meshes,
                       const PageStreamConfig& config)
    : reader_(reader), meshes_(meshes), config_(config) {
  for (uint32_t t = 0; t < std::max(config_.threads, 1u); ++t) threads_.emplace_back([this] { run(); });
}

PageStream::~PageStream() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

bool PageStream::request(uint32_t mesh, uint32_t page) {
  {
    std::lock_guard lock(mutex_);
    if (inFlight_ >= config_.maxInFlight || error_) return false;
    queue_.push_back({mesh, page, nextSequence_++});
    ++inFlight_;
  }
  wake_.notify_one();
  return true;
}

Result<std::vector<StreamedPage>> PageStream::take() {
  std::lock_guard lock(mutex_);
  if (error_) return *error_;
  std::vector<StreamedPage> out = std::move(done_);
  done_.clear();
  inFlight_ -= uint32_t(out.size());
  return out;
}

bool PageStream::waitForArrival(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return arrived_.wait_for(lock, timeout, [&] { return !done_.empty() || error_.has_value(); });
}

uint32_t PageStream::inFlight() const {
  std::lock_guard lock(mutex_);
  return inFlight_;
}

uint64_t PageStream::storedBytes() const {
  std::lock_guard lock(mutex_);
  return storedBytes_;
}

void PageStream::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || (!queue_.empty() && !error_); });
    if (stop_) return;
    auto [mesh, page, sequence] = queue_.front();
    queue_.pop_front();
    lock.unlock();
    // Read, checksums, decompression and decoding happen here, off the caller's thread.
    auto start = std::chrono::steady_clock::now();
    Result<PageData> data = mesh < meshes_.size()
                                ? readPage(reader_, meshes_[mesh], page)
                                : Result<PageData>(makeError(reader_.path(), "page of mesh " + std::to_string(mesh) +
                                                                                 " requested (no such mesh)"));
    uint64_t stored =
        data && page < meshes_[mesh].blocks.blocks.size() ? meshes_[mesh].blocks.blocks[page].storedBytes : 0;
    auto decoded = std::chrono::steady_clock::now();
    std::optional<StreamedPage> done;
    if (data) {
      done = StreamedPage{mesh, page, std::move(data).value(), stored};
      done->seconds = std::chrono::duration<double>(decoded - start).count();
      if (config_.prepare) {
        config_.prepare(*done);
        done->prepareSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - decoded).count();
      }
    }
    lock.lock();
    if (!data) {
      if (!error_) error_ = data.error();
    } else {
      storedBytes_ += stored;
      ready_.emplace(sequence, std::move(*done));
      // Handed over in the order asked for: a page read early waits for the ones before it.
      for (auto it = ready_.begin(); it != ready_.end() && it->first == nextDone_; it = ready_.erase(it), ++nextDone_)
        done_.push_back(std::move(it->second));
    }
    arrived_.notify_all();
  }
}

} // namespace mirage::lod
