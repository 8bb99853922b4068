#include "test_support.h"

#include <cstdlib>
#include <fstream>
#include <unistd.h>
#include <system_error>

namespace mirage::test {

std::filesystem::path sharedData() {
  if (const char* env = std::getenv("MIRAGE_SHARED_DATA")) return env;
  std::filesystem::path p = MIRAGE_SHARED_DATA;
  std::error_code ec;
  return std::filesystem::is_directory(p, ec) ? std::filesystem::canonical(p, ec) : std::filesystem::path{};
}

std::filesystem::path sharedFile(const std::string& relative) {
  std::filesystem::path root = sharedData();
  if (root.empty()) return {};
  std::filesystem::path p = root / relative;
  std::error_code ec;
  return std::filesystem::exists(p, ec) ? p : std::filesystem::path{};
}

std::string mirageBinary() {
  if (const char* bin = std::getenv("MIRAGE_BIN")) return bin;
  return MIRAGE_BINARY_PATH;
}

std::filesystem::path tempDir(const std::string& name) {
  std::filesystem::path p =
      std::filesystem::temp_directory_path() / ("mirage-test-" + std::to_string(::getpid())) / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

std::vector<uint8_t> fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void flipByte(const std::filesystem::path& path, uint64_t at) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(std::streamoff(at));
  char c = 0;
  f.read(&c, 1);
  c = char(c ^ 0x10);
  f.seekp(std::streamoff(at));
  f.write(&c, 1);
}

ImageRGBA8 stereoHalf(const ImageRGBA8& sideBySide, uint32_t eye) {
  ImageRGBA8 half{sideBySide.width / 2, sideBySide.height, {}};
  for (uint32_t y = 0; y < half.height; ++y)
    half.pixels.insert(half.pixels.end(), sideBySide.at(eye * half.width, y),
                       sideBySide.at(eye * half.width, y) + size_t(half.width) * 4);
  return half;
}

} // namespace mirage::test
