// GVS++ configuration JSON (`mirage pvs --config`): accepted configs written back as JSON must parse
// to the same configuration.
#include "fuzz_support.h"
#include "mirage/visibility/gvs.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  Result<vis::GvsConfig> config = vis::parseGvsConfig(text, "gvs.json");
  if (!config) {
    fuzz::checkOneLine(config.error());
    return 0;
  }
  std::string json = vis::gvsConfigToJson(*config);
  Result<vis::GvsConfig> back = vis::parseGvsConfig(json, "again.json");
  if (!back) fuzz::fail("an accepted config written as JSON is rejected: " + back.error().message);
  fuzz::check(vis::gvsConfigToJson(*back) == json, "JSON round trip changes the config");
  return 0;
}
