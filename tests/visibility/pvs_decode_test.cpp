// A PVS chunk whose per-cell sizes claim more than its bytes can hold is rejected before anything
// is allocated for them (a cell claiming 16 GiB of IDs with a 13-byte zstd frame allocated the
// 16 GiB first).
#include <gtest/gtest.h>

#include <cstring>

#include "mirage/asset/bytes.h"
#include "mirage/visibility/pvs_storage.h"

using namespace mirage;

TEST(PvsDecode, SizesBeyondWhatTheBytesCanHoldAreRejectedBeforeAllocating) {
  const uint64_t raw = uint64_t(1) << 34; // within the format's 10 bytes per scene triangle
  asset::ByteWriter w;
  w.write(vis::kPvsChunkVersion);
  w.write(uint64_t(4'000'000'000));
  w.writeVarint(1); // one box cell
  w.write(uint8_t(0));
  for (glm::vec3 v : {glm::vec3(0.0f), glm::vec3(1.0f), glm::vec3(0.0f)}) w.write(v);
  w.write(uint8_t(0)); // full cell
  w.writeVarint(raw);
  // A zstd frame header alone (magic, single segment with an 8-byte content size): it declares the
  // claimed size, so only the bound on what its bytes can expand to catches it.
  std::vector<uint8_t> frame = {0x28, 0xb5, 0x2f, 0xfd, 0xe0};
  frame.resize(13);
  std::memcpy(frame.data() + 5, &raw, 8);
  w.writeVarint(frame.size());
  w.writeBytes(frame);
  auto r = vis::decodePvs(w.take(), "huge.mrg");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("huge.mrg"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("cell 0"), std::string::npos) << r.error().message;
}
