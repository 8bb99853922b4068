#pragma once
// Pieces of a cluster-LOD .mrg that the whole-asset writer (lod_asset.cpp) and the streaming bake
// (stream_bake.cpp) both write, so the two give the same chunk contents.
#include <span>
#include <string>

#include <nlohmann/json.hpp>

#include "mirage/asset/bytes.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod {

// One mesh's entry of the META chunk's "meshes" array (statistics, no timings).
nlohmann::json meshStatsJson(const std::string& name, const ClusterDag& dag);
// The META chunk: format, codec version, source, build settings and the meshes' entries.
std::string lodMetaJson(const std::string& source, const BuildConfig& config, nlohmann::json meshes);
// The 'TMAP' payload in pieces: the header, then one section per mesh in mesh order.
asset::ByteWriter sourceMapHeader(size_t meshCount);
void writeSourceMap(asset::ByteWriter& w, std::span<const uint32_t> map);

// What a reader of the written file gets is what was baked: the same counts and topology
// (positions moved only within the grid's slack; a paged DAG numbers its vertices anew). Empty, or
// "cluster DAG decodes differently" and the like.
std::string dagReadBackDifference(const ClusterDag& written, const ClusterDag& read, bool paged);

} // namespace mirage::lod
