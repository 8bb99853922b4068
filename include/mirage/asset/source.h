#pragma once
// Where an asset's bytes come from: a local file (pread) or an http:// / https:// URL (HTTP range
// requests to any web server that serves byte ranges), read by byte range so that a reader fetches
// only the header, the chunk table and the chunks, blocks and pages it decodes (docs/asset.md,
// "Sources"). Every byte read is still checked against the container's checksums, so a server
// that sends other bytes is caught like a corrupt file.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "mirage/core/result.h"

namespace mirage::asset {

struct SourceOptions {
  // Receive speed limit in bits per second (0: none), to simulate a link (`--bandwidth 20Mbit`):
  // every read, file or URL, returns no sooner than the link would have delivered the bytes read
  // since open (a URL's transfers also through libcurl's receive limit).
  uint64_t bandwidthBitsPerSecond = 0;
  // A remote read that makes no progress for this long fails (never a hang); connecting too.
  uint32_t timeoutSeconds = 30;
};

// Traffic of a source since it was opened: requests made (file: pread calls) and bytes received.
struct SourceStats {
  uint64_t requests = 0, bytes = 0;
};

// Random access to an immutable byte sequence; safe to read from several threads.
class ByteSource {
public:
  virtual ~ByteSource() = default;
  virtual uint64_t size() const = 0;
  // Exactly n bytes at offset (offset + n <= size()) into out: "" on success, else the problem
  // (one line, without the source's name).
  virtual std::string read(uint64_t offset, void* out, size_t n) const = 0;
  virtual SourceStats stats() const = 0;
};

// A link rate as the CLI takes it: a positive number and bit, kbit, Mbit or Gbit (decimal units,
// as links are rated; case-insensitive), e.g. "20Mbit", "1.5Gbit": bits per second. The error
// names the text and the expected form.
Result<uint64_t> parseBandwidth(std::string_view text);

// "http://..." or "https://..." (case-insensitive scheme).
bool isUrl(std::string_view pathOrUrl);

// A regular file (inputFileProblem's wording when it is not one) or a URL. A URL is probed with
// one range request: its size from Content-Range, and an error when the server does not serve
// ranges or answers with an error status. Errors name the path or URL.
Result<std::unique_ptr<ByteSource>> openByteSource(const std::string& pathOrUrl, const SourceOptions& options = {});

} // namespace mirage::asset
