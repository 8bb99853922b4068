#pragma once
// Pages of paged cluster DAGs read on demand on background threads (docs/render.md, "Residency"):
// the caller asks for pages and takes them once read, checked and decoded; it never waits for I/O.
// The reader is a file or a URL (asset/source.h), so the same code streams from a web server.
// Memory is bounded: at most `maxInFlight` pages are queued, being read or arrived and not yet taken.
#include <any>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <vector>

#include "mirage/asset/container.h"
#include "mirage/core/result.h"
#include "mirage/lod/paged_asset.h"

namespace mirage::lod {

struct StreamedPage;

struct PageStreamConfig {
  // Pages asked for and not yet taken (queued, being read, or read): bounds the stream's memory to
  // this many decoded pages (the dragon's: about 0.3 MB each) and the requests a fast view change
  // can pile up. 8 keeps an HTTP link busy (one request after another on one connection); the
  // renderer asks for 32 (ClusterResidencySettings::maxReadsInFlight), a frame's uploads.
  uint32_t maxInFlight = 8;
  // Threads reading, checking and decoding pages at once (pages decode independently; an HTTP
  // source serialises its requests on its connection, the decoding still overlaps). A camera cut
  // asks for many pages at once, and one thread decodes about 100 MB/s of stored pages. The
  // renderer takes the cores it leaves (docs/render.md, "Residency").
  uint32_t threads = 4;
  // Optional: run on the reader thread after a page decoded, before it is handed over (the
  // renderer lays its upload out there, off its own thread); it may fill StreamedPage::prepared
  // and release `data`. It must be safe to call from several threads at once.
  std::function<void(StreamedPage&)> prepare;
};

// One page read and decoded: mesh m's page p, and the bytes its block took in the file.
struct StreamedPage {
  uint32_t mesh = 0, page = 0;
  PageData data;
  uint64_t storedBytes = 0;
  double seconds = 0;        // the reader thread's time on it: read, checksums, decompression, decoding
  double prepareSeconds = 0; // and in PageStreamConfig::prepare
  std::any prepared;         // what PageStreamConfig::prepare made of it
};

class PageStream {
public:
  // `reader` and `meshes` must outlive the stream (the thread reads through them).
  PageStream(const asset::AssetReader& reader, std::span<const PagedMesh> meshes, const PageStreamConfig& config = {});
  ~PageStream(); // stops after the read in progress (queued pages are dropped)
  PageStream(const PageStream&) = delete;
  PageStream& operator=(const PageStream&) = delete;

  // Queues a read of (mesh, page); false when maxInFlight pages are already asked for.
  bool request(uint32_t mesh, uint32_t page);
  // The pages read since the last call, in the order they were asked for. A read or decode error
  // (a checksum, a lost connection) stops the stream: this call returns it (one line naming the
  // file, chunk and page), and so does every later one.
  Result<std::vector<StreamedPage>> take();
  // Blocks until a page arrived (or an error happened), at most `timeout`; true when one did.
  // For callers that want a finished image (a converged render), never for a frame loop.
  bool waitForArrival(std::chrono::milliseconds timeout);
  uint32_t inFlight() const;    // asked for and not yet taken
  uint64_t storedBytes() const; // block bytes read so far
  // Bytes the reader's source delivered since it was opened (asset::SourceStats): the index and
  // root pages read at open, the pages, and anything else read through the same reader.
  uint64_t receivedBytes() const { return reader_.sourceStats().bytes; }
  uint32_t capacity() const { return config_.maxInFlight; }

private:
  void run();

  const asset::AssetReader& reader_;
  std::span<const PagedMesh> meshes_;
  PageStreamConfig config_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, arrived_;
  struct Request {
    uint32_t mesh, page;
    uint64_t sequence; // the order asked for: pages are handed over in it
  };
  std::deque<Request> queue_;                // not yet read
  std::map<uint64_t, StreamedPage> ready_;   // read ahead of an earlier page still being read
  std::vector<StreamedPage> done_;           // read, in order, not yet taken
  uint64_t nextSequence_ = 0, nextDone_ = 0; // the next request's number; the next page to hand over
  uint32_t inFlight_ = 0;
  uint64_t storedBytes_ = 0;
  std::optional<Error> error_;
  bool stop_ = false;
  std::vector<std::thread> threads_; // last: started once everything above exists
};

} // namespace mirage::lod
