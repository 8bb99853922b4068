#pragma once
// Shared by the protocol and patch-section tests: a message decoded as the peer "peer" and the
// check that a decode failed with one line, from that peer, naming the part expected.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/stream/protocol.h"

namespace mirage::test {

inline Result<stream::Message> decode(const std::vector<uint8_t>& bytes, const stream::DecodeLimits& limits = {}) {
  return stream::decodeMessage(bytes, limits, "peer");
}

inline void expectError(const Result<stream::Message>& result, const std::string& part) {
  ASSERT_FALSE(result.ok()) << "accepted, expected an error with '" << part << "'";
  EXPECT_NE(result.error().message.find(part), std::string::npos) << result.error().message;
  EXPECT_EQ(result.error().message.find('\n'), std::string::npos) << result.error().message;
  EXPECT_EQ(result.error().message.rfind("peer: ", 0), 0u) << result.error().message;
}

} // namespace mirage::test
