// HTTP(S) byte source: range requests through libcurl (docs/asset.md, "Sources").
//
// One easy handle per source, so consecutive reads reuse the connection (keep-alive); a mutex
// makes reads from several threads take turns on it. A read smaller than kReadAhead fetches
// kReadAhead bytes (clipped to the file) and keeps them: opening a container makes a few small
// reads at its start (magic, version, header) and one of the chunk table, and a paged reader asks
// for a block's index before the block.
#include "source_http.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <mutex>
#include <vector>

#include <curl/curl.h>

#include "mirage/core/input_text.h"

namespace mirage::asset::detail {
namespace {

constexpr size_t kReadAhead = 64 * 1024;

// What one request may receive: exactly `want` bytes into `out`; more is an error (a server that
// ignores the range and sends the whole file is stopped at the first excess byte).
struct Receive {
  uint8_t* out = nullptr;
  size_t want = 0, got = 0;
  bool overflow = false;
  std::string contentRange; // the Content-Range header's value
};

size_t onBody(char* data, size_t size, size_t count, void* user) {
  auto* r = static_cast<Receive*>(user);
  size_t n = size * count;
  if (n > r->want - r->got) {
    r->overflow = true;
    return 0; // aborts the transfer (CURLE_WRITE_ERROR)
  }
  std::memcpy(r->out + r->got, data, n);
  r->got += n;
  return n;
}

size_t onHeader(char* data, size_t size, size_t count, void* user) {
  auto* r = static_cast<Receive*>(user);
  size_t n = size * count;
  std::string_view line(data, n);
  constexpr std::string_view kName = "content-range:";
  if (line.size() > kName.size()) {
    bool match = true;
    for (size_t i = 0; i < kName.size() && match; ++i)
      match = std::tolower(static_cast<unsigned char>(line[i])) == kName[i];
    if (match) {
      std::string_view value = line.substr(kName.size());
      while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
      while (!value.empty() && (value.back() == '\r' || value.back() == '\n' || value.back() == ' '))
        value.remove_suffix(1);
      r->contentRange = std::string(value);
    }
  }
  return n;
}

// "bytes FIRST-LAST/TOTAL" or "bytes */TOTAL" (416): false when malformed or TOTAL is "*".
bool parseContentRange(const std::string& v, uint64_t& first, uint64_t& last, uint64_t& total, bool& unsatisfied) {
  unsigned long long a = 0, b = 0, t = 0;
  int used = 0;
  if (std::sscanf(v.c_str(), "bytes */%llu%n", &t, &used) == 1 && size_t(used) == v.size()) {
    unsatisfied = true, total = t;
    return true;
  }
  if (std::sscanf(v.c_str(), "bytes %llu-%llu/%llu%n", &a, &b, &t, &used) == 3 && size_t(used) == v.size() && a <= b &&
      b < t) {
    unsatisfied = false, first = a, last = b, total = t;
    return true;
  }
  return false;
}

std::string statusProblem(long status) {
  std::string s = "HTTP " + std::to_string(status);
  switch (status) {
  case 401:
  case 403:
    return s + " (access denied)";
  case 404:
    return s + " (not found)";
  case 410:
    return s + " (gone)";
  default:
    return status >= 500 ? s + " (server error)" : s;
  }
}

class HttpSource final : public ByteSource {
public:
  HttpSource(CURL* curl, std::string url) : curl_(curl), url_(std::move(url)) {}
  ~HttpSource() override { curl_easy_cleanup(curl_); }
  HttpSource(const HttpSource&) = delete;
  HttpSource& operator=(const HttpSource&) = delete;

  uint64_t size() const override { return size_; }
  SourceStats stats() const override {
    std::lock_guard lock(mutex_);
    return stats_;
  }

  std::string read(uint64_t offset, void* out, size_t n) const override {
    if (offset > size_ || n > size_ - offset) return "read past the end of the file";
    if (n == 0) return {};
    std::lock_guard lock(mutex_);
    if (offset >= cacheOffset_ && offset - cacheOffset_ <= cache_.size() &&
        n <= cache_.size() - (offset - cacheOffset_)) {
      if (n) std::memcpy(out, cache_.data() + (offset - cacheOffset_), n);
      return {};
    }
    if (n >= kReadAhead) return fetch(offset, static_cast<uint8_t*>(out), n);
    size_t span = size_t(std::min<uint64_t>(kReadAhead, size_ - offset));
    cache_.resize(span);
    cacheOffset_ = offset;
    if (std::string problem = fetch(offset, cache_.data(), span); !problem.empty()) {
      cache_.clear();
      return problem;
    }
    if (n) std::memcpy(out, cache_.data(), n);
    return {};
  }

  // The probe: the first kReadAhead bytes (or the whole file when smaller), which also gives the
  // size. A server that answers 200 with the whole file is accepted only when the file fits.
  std::string probe() {
    cache_.resize(kReadAhead);
    cacheOffset_ = 0;
    long status = 0;
    Receive r;
    if (std::string problem = request(0, cache_.data(), kReadAhead, r, status); !problem.empty()) return problem;
    if (status == 200) { // the whole file, and it fit
      cache_.resize(r.got);
      size_ = r.got;
      return {};
    }
    uint64_t first = 0, last = 0, total = 0;
    bool unsatisfied = false;
    if (!parseContentRange(r.contentRange, first, last, total, unsatisfied))
      return "malformed Content-Range " + quoteInput(r.contentRange);
    if (status == 416) { // an empty file
      if (!unsatisfied || total != 0) return statusProblem(status);
      cache_.clear();
      size_ = 0;
      return {};
    }
    if (first != 0 || r.got != last + 1) return "the server sent another range than asked for";
    cache_.resize(r.got);
    size_ = total;
    return {};
  }

private:
  // Exactly n bytes at offset into out (HTTP 206 with that Content-Range).
  std::string fetch(uint64_t offset, uint8_t* out, size_t n) const {
    long status = 0;
    Receive r;
    if (std::string problem = request(offset, out, n, r, status); !problem.empty()) return problem;
    if (status == 200) return "the server does not serve byte ranges (HTTP 200 to a range request)";
    uint64_t first = 0, last = 0, total = 0;
    bool unsatisfied = false;
    if (!parseContentRange(r.contentRange, first, last, total, unsatisfied) || unsatisfied)
      return "malformed Content-Range " + quoteInput(r.contentRange);
    if (total != size_) return "the file changed on the server since it was opened";
    if (first != offset || last + 1 != offset + n || r.got != n) return "the server sent another range than asked for";
    return {};
  }

  // One GET of bytes offset .. offset + n - 1. Success ("") means a 200 or 206 body that fit in n
  // bytes; status receives the HTTP status whenever there was a response.
  std::string request(uint64_t offset, uint8_t* out, size_t n, Receive& r, long& status) const {
    r.out = out;
    r.want = n;
    std::string range = std::to_string(offset) + "-" + std::to_string(offset + n - 1);
    char errors[CURL_ERROR_SIZE] = {};
    curl_easy_setopt(curl_, CURLOPT_RANGE, range.c_str());
    curl_easy_setopt(curl_, CURLOPT_WRITEDATA, &r);
    curl_easy_setopt(curl_, CURLOPT_HEADERDATA, &r);
    curl_easy_setopt(curl_, CURLOPT_ERRORBUFFER, errors);
    CURLcode code = curl_easy_perform(curl_);
    curl_easy_setopt(curl_, CURLOPT_ERRORBUFFER, nullptr);
    ++stats_.requests;
    stats_.bytes += r.got;
    curl_easy_getinfo(curl_, CURLINFO_RESPONSE_CODE, &status);
    if (code == CURLE_WRITE_ERROR && r.overflow) {
      if (status == 200) return "the server does not serve byte ranges (HTTP 200 to a range request)";
      return status == 206 ? "the server sent more than the range asked for" : statusProblem(status);
    }
    if (code != CURLE_OK) return escapeInput(errors[0] ? errors : curl_easy_strerror(code), 200);
    // 416: the probe's empty file (fetch() never asks past the end, and rejects it).
    if (status != 200 && status != 206 && status != 416) return statusProblem(status);
    return {};
  }

  CURL* curl_;
  std::string url_;
  uint64_t size_ = 0;
  mutable std::mutex mutex_;
  mutable std::vector<uint8_t> cache_; // bytes cacheOffset_ .. + size of the last small read's fetch
  mutable uint64_t cacheOffset_ = 0;
  mutable SourceStats stats_;
};

} // namespace

Result<std::unique_ptr<ByteSource>> openHttp(const std::string& url, const SourceOptions& options) {
  std::string name = escapeInput(url, 200);
  static std::once_flag once;
  static CURLcode initCode = CURLE_OK;
  std::call_once(once, [] { initCode = curl_global_init(CURL_GLOBAL_DEFAULT); });
  if (initCode != CURLE_OK) return makeError(name, std::string("libcurl: ") + curl_easy_strerror(initCode));
  CURL* curl = curl_easy_init();
  if (!curl) return makeError(name, "libcurl: cannot create a transfer");
  auto source = std::make_unique<HttpSource>(curl, url);
  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_NOSIGNAL, 1L); // timeouts without signals: safe in threads
  curl_easy_setopt(curl, CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(curl, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(curl, CURLOPT_FOLLOWLOCATION, 1L);
  curl_easy_setopt(curl, CURLOPT_MAXREDIRS, 5L);
  curl_easy_setopt(curl, CURLOPT_USERAGENT, "mirage");
  curl_easy_setopt(curl, CURLOPT_CONNECTTIMEOUT, long(options.timeoutSeconds));
  // Stalled transfers end: under one byte per second for the timeout.
  curl_easy_setopt(curl, CURLOPT_LOW_SPEED_LIMIT, 1L);
  curl_easy_setopt(curl, CURLOPT_LOW_SPEED_TIME, long(options.timeoutSeconds));
  if (options.bandwidthBitsPerSecond)
    curl_easy_setopt(curl, CURLOPT_MAX_RECV_SPEED_LARGE, curl_off_t(options.bandwidthBitsPerSecond / 8));
  curl_easy_setopt(curl, CURLOPT_WRITEFUNCTION, onBody);
  curl_easy_setopt(curl, CURLOPT_HEADERFUNCTION, onHeader);
  if (std::string problem = source->probe(); !problem.empty()) return makeError(name, problem);
  return std::unique_ptr<ByteSource>(std::move(source));
}

} // namespace mirage::asset::detail
