#pragma once
// Shared plumbing of the fuzz targets (fuzz/README.md). Each target defines LLVMFuzzerTestOneInput;
// built with -fsanitize=fuzzer it is a libFuzzer binary, built with replay_main.cpp it runs given
// files once (the regression tests of every build).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::fuzz {

// A private directory for this process (removed at exit): the importers take paths, so inputs are
// written here first. Separate per process because libFuzzer's -jobs/-fork run several at once.
const std::filesystem::path& scratchDir();
// Writes `bytes` to scratchDir()/name (replacing it) and returns the path.
std::filesystem::path writeScratch(const std::string& name, std::span<const uint8_t> bytes);
std::filesystem::path writeScratch(const std::string& name, std::string_view text);

// A broken invariant: prints the message and aborts, so the fuzzer records the input as a crash.
[[noreturn]] void fail(const std::string& what);
inline void check(bool ok, const std::string& what) {
  if (!ok) fail(what);
}
// An error message must be one line (the CLI prints it as is).
void checkOneLine(const Error& error);

// What every importer promises (import.h): the scene passes validateScene, which is also what
// `mirage build` needs; then the scene is encoded and decoded as a SCEN chunk.
void checkImportedScene(const Scene& scene, const std::string& file);

} // namespace mirage::fuzz

#include <vector>

#include "mirage/asset/container.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::fuzz {

struct Chunk {
  asset::FourCC type;
  std::vector<uint8_t> bytes;
};

// Bytes that start like a blocked payload (asset/blocks.h) with its checksums recomputed where the
// bytes allow: the index checksum, each block's stored checksum, and the raw checksum of blocks
// stored raw (a compressed block's raw checksum stays: the fuzzer's bytes still reach zstd). Other
// bytes are returned unchanged. Lets fuzzed block tables reach the checks behind the checksums.
std::vector<uint8_t> resealBlocks(std::span<const uint8_t> bytes);

// A .mrg in the scratch directory holding `chunks` (stored raw: the fuzzer's bytes reach the
// decoders with valid checksums; bytes that form a blocked payload, resealed, as a blocked chunk).
std::filesystem::path writeMrg(const std::string& name, std::span<const Chunk> chunks);
// Every chunk of a .mrg, decompressed (a blocked chunk: its payload as stored, blocks checked).
std::vector<Chunk> readMrg(const std::filesystem::path& path);
// The chunks of a small baked cluster-LOD asset (a 320-triangle blob: SCEN, CDAG, TMAP, META),
// made once per process: the valid neighbours a fuzzed chunk is placed among.
const std::vector<Chunk>& lodAssetChunks();
// What every consumer of a decoded DAG relies on without checking: all ids and ranges in bounds.
void checkDag(const lod::ClusterDag& dag);
// Runs every loader of .mrg files on `path` (scene, cluster-LOD asset, surfels, PVS) and checks
// what each accepted against its documented contract.
void loadEveryWay(const std::filesystem::path& path);

} // namespace mirage::fuzz
