#pragma once
// The paged cluster DAG in a .mrg file (docs/lod.md, "Paged chunk"): one 'CPAG' chunk per mesh, a
// blocked chunk (asset/blocks.h) whose index header holds the page table and the DAG's few
// page-independent fields, and whose block p is page p (paging.h), so page order is the blocks'
// order and a load order. A reader fetches the chunk indices up front (one read each), then any
// page by number; every page is checked (block checksums, then decodePage against the table).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mirage/asset/blocks.h"
#include "mirage/asset/container.h"
#include "mirage/core/result.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/paging.h"

namespace mirage::lod {

// Version 2 added the positions' box and the pages' vertex-id counts (what a renderer sizes and
// frames before any page arrives); version 1 files are refused (rebuild them).
inline constexpr uint32_t kPagedChunkVersion = 2;

// What a DAG holds beyond its pages and page table (reassemblePagedDag restores the DAG fields),
// and what a reader that loads pages on demand needs up front.
struct PagedDagRest {
  uint64_t inputTriangles = 0;
  std::vector<float> groupSimplifyError; // per group
  std::vector<uint32_t> roots;           // the DAG's root list, in its order
  std::vector<LevelStats> levels;
  // The box of every decoded position a cluster uses (the bounds a renderer of the whole DAG
  // computes), so a renderer frames and culls the mesh before its pages arrive.
  Bounds positionBounds;
  // Per page: its clusters' vertex counts summed (the vertex ids it holds), so the GPU memory a page
  // takes is known before it is read.
  std::vector<uint32_t> pageClusterVertices;
};

// The blocked payload of one mesh's 'CPAG' chunk: buildPages(dag, config), the table and the rest
// as the index header, one zstd block per page. Fails when the header exceeds the block index's
// limit (asset::kMaxBlockHeaderBytes: a table for about 35 M input triangles).
Result<std::vector<uint8_t>> encodePagedChunk(const ClusterDag& dag, const PageConfig& config, int zstdLevel);

// One paged mesh of an open file: its chunk, block index, page table and rest.
struct PagedMesh {
  size_t chunk = 0; // index in AssetReader::chunks()
  asset::BlockTable blocks;
  PageTable table;
  PagedDagRest rest;
};

// The index header of a 'CPAG' chunk (blocks.header); `context` names file and chunk in errors.
Result<PagedMesh> decodePagedHeader(std::span<const uint8_t> header, const std::string& context);
// Every 'CPAG' chunk of `reader`, in file order (= mesh order), reading only their indices.
Result<std::vector<PagedMesh>> openPagedMeshes(const asset::AssetReader& reader);
// Page `page` of `mesh`: its block (checksums, decompression), then decodePage against the table.
// Errors name the file, the chunk and the page.
Result<PageData> readPage(const asset::AssetReader& reader, const PagedMesh& mesh, uint32_t page);

// A paged .mrg opened for on-demand pages (GPU residency, docs/render.md "Residency"): the scene,
// the META chunk, every mesh's index (table and rest) and root pages, and the reader for the rest;
// no other page is read. Memory: the tables and the root pages.
struct PagedLodAsset {
  Scene scene;                                  // meshes keep name, material and bounds, no geometry
  std::string metaJson;                         // build settings and statistics as written
  std::vector<PagedMesh> meshes;                // one per scene mesh
  std::vector<std::vector<PageData>> rootPages; // per mesh: its pages [0, rootPageCount)
  std::unique_ptr<asset::AssetReader> reader;   // open for the pages (a file or a URL)
};
// `path` is a file or an http(s) URL; errors for a file that is not paged ("needs a paged asset
// (mirage build --paged)"), one without a 'CPAG' chunk per mesh, and any bad index or root page.
Result<PagedLodAsset> openPagedLodAsset(const std::string& path, const asset::SourceOptions& options = {});

// The DAG from its table, rest and every page (pages[p] = page p): equal to decodeDag of the same
// DAG's CDAG chunk except for the numbering of vertices (dagDifference): attribute vertices are the
// distinct (position, normal, uv) of the pages and welded positions the distinct positions, each
// numbered by first use in cluster order. Checked with checkDagStructure.
Result<ClusterDag> reassemblePagedDag(const PageTable& table, const PagedDagRest& rest, std::span<const PageData> pages,
                                      const std::string& context);
// The DAG of one 'CPAG' payload in memory (encodePagedChunk's bytes): every block checked and
// decoded, every page against the table, then reassemblePagedDag. Errors start with `context`.
Result<ClusterDag> decodePagedChunk(std::span<const uint8_t> payload, const std::string& context);
// readPage for every page, then reassemblePagedDag.
Result<ClusterDag> readPagedDag(const asset::AssetReader& reader, const PagedMesh& mesh);

// Empty when `a` and `b` are the same DAG up to the numbering of attribute vertices and welded
// positions: clusters (offsets, counts, links, bounds bit for bit), indices, groups, children,
// parents, roots, levels; per cluster corner the same position, normal and uv bits; corners that
// share a welded position in one share it in the other. Otherwise the first difference.
std::string dagDifference(const ClusterDag& a, const ClusterDag& b);

} // namespace mirage::lod
