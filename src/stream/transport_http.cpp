// Static files for the browser client. Only plain names are served: a target is split into
// segments of [A-Za-z0-9._-] that do not start with '.', so "..", "%2e%2e", backslashes and
// absolute paths never reach the file system, and the resolved path (symbolic links followed) must
// still lie inside the directory.
#include "transport_http.h"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <system_error>

#include "mirage/stream/transport.h"

namespace mirage::stream {
namespace {

// Larger files are not part of a browser client.
constexpr uintmax_t kMaxStaticFileBytes = 32u << 20;

bool plainSegment(std::string_view segment) {
  if (segment.empty() || segment.front() == '.') return false;
  return std::all_of(segment.begin(), segment.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '-' ||
           c == '_';
  });
}

std::string contentType(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".wasm") return "application/wasm";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

ws::HttpReply textReply(int status, const std::string& body) {
  return ws::HttpReply{status, "text/plain", body + "\n"};
}

} // namespace

std::filesystem::path staticFilePath(const std::filesystem::path& dir, std::string_view target) {
  if (dir.empty()) return {};
  size_t query = target.find_first_of("?#");
  if (query != std::string_view::npos) target = target.substr(0, query);
  if (target.empty() || target.front() != '/') return {};
  std::string_view rest = target.substr(1);
  std::filesystem::path relative;
  if (rest.empty()) relative = "index.html";
  while (!rest.empty()) {
    size_t slash = rest.find('/');
    std::string_view segment = rest.substr(0, slash);
    if (!plainSegment(segment)) return {};
    relative /= std::string(segment);
    rest = slash == std::string_view::npos ? std::string_view() : rest.substr(slash + 1);
    if (slash != std::string_view::npos && rest.empty()) return {}; // trailing '/'
  }
  std::error_code ec;
  std::filesystem::path root = std::filesystem::weakly_canonical(dir, ec);
  if (ec) return {};
  if (!root.has_filename()) root = root.parent_path(); // "dir/" ends in an empty element
  std::filesystem::path file = std::filesystem::weakly_canonical(root / relative, ec);
  if (ec) return {};
  auto [rootEnd, fileIt] = std::mismatch(root.begin(), root.end(), file.begin(), file.end());
  if (rootEnd != root.end() || fileIt == file.end()) return {};
  return file;
}

ws::HttpReply serveStaticFile(const std::filesystem::path& dir, const std::string& method, const std::string& target) {
  if (method != "GET" && method != "HEAD") return textReply(405, "method not allowed");
  if (dir.empty()) return textReply(404, "not found");
  std::filesystem::path file = staticFilePath(dir, target);
  if (file.empty()) return textReply(403, "forbidden");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return textReply(404, "not found");
  uintmax_t size = std::filesystem::file_size(file, ec);
  if (ec || size > kMaxStaticFileBytes) return textReply(404, "not found");
  std::ifstream in(file, std::ios::binary);
  std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in && !in.eof()) return textReply(404, "not found");
  if (method == "HEAD") body.clear();
  return ws::HttpReply{200, contentType(file), std::move(body)};
}

} // namespace mirage::stream
