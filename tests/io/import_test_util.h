#pragma once
// Helpers shared by the importer tests: binary bytes into a string, input files written, and the
// one-line error check.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::test {

// Appends v's bytes (host order, or reversed for big-endian files).
template <class T> void put(std::string& s, T v, bool bigEndian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (bigEndian) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

// Writes `bytes` to `p` (a test input), returning `p`.
inline std::filesystem::path writeFile(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

// Error must name the file, mention the problem, and be one line.
inline void expectError(const Result<Scene>& r, const std::filesystem::path& file, const std::string& phrase) {
  ASSERT_FALSE(r.ok()) << "expected an error containing '" << phrase << "'";
  const std::string& msg = r.error().message;
  EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find(phrase), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

} // namespace mirage::test
