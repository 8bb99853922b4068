#pragma once
// Shared helpers for Mirage tests.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mirage/core/image.h"

namespace mirage::test {

// ../shared/data beside the checkout (CI has it). Empty path when absent.
std::filesystem::path sharedData();
// A file under ../shared/data, or empty when the data set is absent (callers GTEST_SKIP with a message).
std::filesystem::path sharedFile(const std::string& relative);
// The mirage CLI built beside the tests (MIRAGE_BIN overrides the compiled-in path).
std::string mirageBinary();
// A fresh, empty temporary directory for this test, removed at process exit.
std::filesystem::path tempDir(const std::string& name);
// The bytes of a file (empty when it cannot be read).
std::vector<uint8_t> fileBytes(const std::filesystem::path& path);
// Flips bit 4 of the byte at `at` in the file, in place (damaged-file tests).
void flipByte(const std::filesystem::path& path, uint64_t at);
// One eye's half (0 left, 1 right) of a side-by-side stereo image.
ImageRGBA8 stereoHalf(const ImageRGBA8& sideBySide, uint32_t eye);

} // namespace mirage::test

// Skip the current test with a message when a data file is absent.
#define MIRAGE_REQUIRE_DATA(var, relative)                                                                             \
  auto var = ::mirage::test::sharedFile(relative);                                                                     \
  if (var.empty()) GTEST_SKIP() << "shared data absent: ../shared/data/" << (relative)
