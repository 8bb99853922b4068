#include "mirage/core/input_text.h"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include <sys/stat.h>

namespace mirage {

std::string inputFileProblem(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return "file not found";
    if (errno == EACCES) return "permission denied";
    return std::strerror(errno);
  }
  if (S_ISREG(st.st_mode)) return "";
  if (S_ISDIR(st.st_mode)) return "is a directory, not a regular file";
  if (S_ISFIFO(st.st_mode)) return "is a FIFO (named pipe), not a regular file";
  if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "is a device, not a regular file";
  if (S_ISSOCK(st.st_mode)) return "is a socket, not a regular file";
  return "not a regular file";
}

Result<std::string> readInputText(const std::filesystem::path& path, uint64_t maxBytes, std::string_view what) {
  std::string name = path.string();
  if (std::string problem = inputFileProblem(path); !problem.empty()) return Error{name + ": " + problem};
  std::error_code ec;
  uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) return Error{name + ": cannot read: " + ec.message()};
  if (size > maxBytes)
    return Error{name + ": " + std::to_string(size) + " bytes, more than " + std::string(what) + " may hold (" +
                 std::to_string(maxBytes) + ")"};
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) return Error{name + ": cannot read"};
  return text.str();
}

namespace {

// Length of the well-formed UTF-8 sequence starting at s[0] that encodes a printable code point above U+009F
// (no overlong forms, surrogates or C1 controls), or 0.
size_t utf8Printable(std::string_view s) {
  const auto b = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char c = b(0);
  size_t len = c >= 0xf0 && c <= 0xf4 ? 4 : c >= 0xe0 ? 3 : c >= 0xc2 && c <= 0xdf ? 2 : 0;
  if (c >= 0xf5 || len == 0 || s.size() < len) return 0;
  uint32_t cp = c & (0x7f >> len);
  for (size_t i = 1; i < len; ++i) {
    if ((b(i) & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (b(i) & 0x3f);
  }
  static constexpr uint32_t kMin[] = {0, 0, 0xa0, 0x800, 0x10000};
  if (cp < kMin[len] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return len;
}

} // namespace

std::string escapeInput(std::string_view raw, size_t maxBytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  const size_t n = std::min(raw.size(), maxBytes);
  for (size_t i = 0; i < n;) {
    unsigned char c = static_cast<unsigned char>(raw[i]);
    if (c == '\\') {
      out += "\\\\";
    } else if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else if (size_t len = utf8Printable(raw.substr(i, n - i)); len > 0) {
      out.append(raw.substr(i, len));
      i += len;
      continue;
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
    ++i;
  }
  if (raw.size() > n) out += "...";
  return out;
}

std::string quoteInput(std::string_view raw, size_t maxBytes) {
  std::string out(1, '\'');
  out += escapeInput(raw, maxBytes);
  out += '\'';
  return out;
}

} // namespace mirage
