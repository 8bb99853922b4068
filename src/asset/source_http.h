#pragma once
// The HTTP(S) byte source (libcurl): one range request per read, with a small read-ahead for the
// container's many small header reads.
#include "mirage/asset/source.h"

namespace mirage::asset::detail {

Result<std::unique_ptr<ByteSource>> openHttp(const std::string& url, const SourceOptions& options);

} // namespace mirage::asset::detail
