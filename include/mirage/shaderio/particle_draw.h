// Particle drawing (src/render/particle_draw*.cpp, shaders/particle_*.{vert,frag,comp}): what the
// billboard draws and the compute passes (sort, splat) push and read, written once for C++ and GLSL.
#ifndef MIRAGE_SHADERIO_PARTICLE_DRAW_H
#define MIRAGE_SHADERIO_PARTICLE_DRAW_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using uint = uint32_t;
using mat4 = glm::mat4;
#endif

// ParticleBatchInfo::flags, ParticleDrawPush::flags
#define MIRAGE_PARTICLE_ALPHA_FROM_GREY 1u

// ParticleDrawPush::mode: what a billboard instance names.
#define MIRAGE_PARTICLE_DRAW_RECORDS 0u // record gl_InstanceIndex of recordAddress; sheet etc. from the push
#define MIRAGE_PARTICLE_DRAW_KEYS 1u    // global record uint(uint64 keys[gl_InstanceIndex]) (sorted mode)
#define MIRAGE_PARTICLE_DRAW_INDICES 2u // global record uint indices[gl_InstanceIndex] (the splat's large ones)

// Workgroup size of the particle compute passes (one thread per record slot).
#define MIRAGE_PARTICLE_DRAW_GROUP 256

// One batch as the compute passes and the list-driven draws see it: batches' records are numbered
// globally, batch b's record i being global record first + i (first = the capacities before it).
struct ParticleBatchInfo {
  uint64_t records; // RenderParticle[]
  uint first;       // global index of record 0
  uint capacity;    // records room (the live count is the batch's draw argument instanceCount)
  uint sheet;
  uint tilesX;
  uint tilesY;
  uint flags; // MIRAGE_PARTICLE_*
};

struct ParticleDrawPush {
  uint64_t frameAddress;  // ViewFrame of the eye (the first member of FrameData and ClusterFrame)
  uint64_t recordAddress; // RECORDS: RenderParticle[]; KEYS: uint64 keys; INDICES: uint global indices
  uint64_t oitAddress;    // OitLists (shaderio/oit.h) in linked-list mode, else 0
  uint64_t batchAddress;  // ParticleBatchInfo[batchCount] (KEYS, INDICES)
  uint sheet;             // RECORDS: index into the sheet array
  uint tilesX;
  uint tilesY;
  uint flags; // MIRAGE_PARTICLE_*
  uint mode;  // MIRAGE_PARTICLE_DRAW_*
  uint batchCount;
  uint pad0, pad1;
};

// The sorted mode's compute passes (particle_sort_keys.comp, particle_sort_gaps.comp): keys
// (view-depth order bits << 32 | global record, ~0 for empty slots) of every record slot, then,
// after the sort, each sorted key's gap among the blended triangles sorted on the CPU.
struct ParticleSortPush {
  mat4 view;             // eye 0's world -> view (the triangles' sort view)
  uint64_t batchAddress; // ParticleBatchInfo[batchCount]
  uint64_t argsAddress;  // VkDrawIndirectCommand per batch: instanceCount = its live records
  uint64_t keyAddress;   // uint64[total]
  uint64_t depthAddress; // float[triangleCount]: the triangles' view z, ascending (farthest first)
  uint64_t gapAddress;   // VkDrawIndirectCommand[triangleCount + 1], zeroed: each gap's draw
  uint total;            // record slots over all batches
  uint batchCount;
  uint triangleCount;
  uint pad0;
};

// The splat (particle_splat*.comp; docs/particles.md, "Splat"): per target pixel
// MIRAGE_SPLAT_CHANNELS sums, the weighted blended accumulators of McGuire and Bavoil 2013:
// premultiplied colour x weight (rgb), alpha x weight, and -log(1 - alpha) (the revealage product
// as a sum, so that it can be accumulated by atomic adds). Float: float[pixel * 5 + c]; fixed
// point (without float atomic adds): uint64[pixel * 5 + c] in units of 2^-MIRAGE_SPLAT_FIXED_BITS.
#define MIRAGE_SPLAT_CHANNELS 5
#define MIRAGE_SPLAT_FIXED_BITS 32
// Coverage past this (a splat's alpha is a pixel's share of a particle's) counts as this: the
// revealage sum stays finite.
#define MIRAGE_SPLAT_MAX_ALPHA 0.99975
// Largest splatBelowPixels: a splatted particle touches at most (ceil(it) + 1)^2 pixels.
#define MIRAGE_SPLAT_MAX_PIXELS 8.0

// The binned splat (particle_splat_bin.glsl, particle_splat_scan.comp, particle_splat_tiles.glsl):
// the target cut into square tiles per eye; the particles counted per tile, the counts scanned,
// each particle's entries (one per tile its footprint overlaps, per eye) scattered into its tiles'
// lists, then one workgroup per chunk of a tile's list sums them in shared memory and writes the
// tile's pixels once. Tile edge in pixels: a tile-pass workgroup has an invocation per pixel.
#define MIRAGE_SPLAT_TILE 16
// Entries per tile-pass workgroup: a hot tile's list is split over this many workgroups, each
// adding its sums to the tile's pixels (a tile of one chunk stores them).
#define MIRAGE_SPLAT_CHUNK 2048
// Record slots per invocation of the count and scatter passes (a workgroup takes
// MIRAGE_PARTICLE_DRAW_GROUP times this many): a workgroup counts its entries per tile in shared
// memory and takes one global atomic per tile it touches, not one per entry (an effect on a few
// hundred tiles made every tile counter a hot spot: 12.7 M same-address atomics a pass at 10 M).
#define MIRAGE_SPLAT_BIN_RECORDS 16
// The count and scatter passes' shared table of the tiles a workgroup touches (open addressing,
// a power of two; ParticleDrawSettings::splatBinSlots may use fewer) and the slots an entry
// probes: a tile that finds none of its probes free is counted and placed by global atomics per
// entry instead.
#define MIRAGE_SPLAT_BIN_SLOTS 2048
#define MIRAGE_SPLAT_BIN_SLOT_BITS 11
#define MIRAGE_SPLAT_BIN_PROBES 8
// Default entry room per record slot (ParticleDrawSettings::splatEntryRoom): a footprint of at
// most 2 px overlaps 1.27 tiles of 16 px on average (4 at most), per eye, so a stereo frame's
// ~2.5 fit too; entries past the room are splatted directly with the global atomics, so the image
// does not depend on it.
#define MIRAGE_SPLAT_ENTRIES_PER_RECORD 3
// The bins buffer: uint[MIRAGE_SPLAT_BIN_HEADER + 3 tiles + 2]: the header (the tile pass's
// VkDispatchIndirectCommand, then its chunks and the entries listed), per tile its count (the
// scatter's cursor after the scan), per tile + 1 its first entry, per tile + 1 its first chunk.
#define MIRAGE_SPLAT_BIN_HEADER 8
#define MIRAGE_SPLAT_BIN_CHUNKS 3  // header word: chunks over all tiles (tile-pass workgroups)
#define MIRAGE_SPLAT_BIN_ENTRIES 4 // header word: entries over all tiles (may exceed the room)
// ParticleSplatPush::phase of particle_splat_bin*.comp.
#define MIRAGE_SPLAT_PHASE_COUNT 0u   // classify, list the billboards, count the entries per tile
#define MIRAGE_SPLAT_PHASE_SCATTER 1u // write the entries into their tiles' lists

// One splatted particle as one tile's list holds it (splatPack in particle_splat.glsl), 16 bytes:
// the footprint's corner relative to the tile (x and y, 16 bits each, in 1/MIRAGE_SPLAT_SUBPIXELS
// px offset by 2^15), its edge (16 bits, the same unit) and alpha (16-bit unorm), its NDC depth
// (float; the weight follows from it) and colour (10-bit unorm r, g, b). The tile pass reads its
// list in order instead of classifying each particle's record again (a gather of 32 bytes, its
// batch, the sheet and the camera per entry). The corner and edge stay on this grid and the colour
// so rounded in every path, so that the binned and the atomic splat sum the same values.
#define MIRAGE_SPLAT_ENTRY_BYTES 16
#define MIRAGE_SPLAT_SUBPIXELS 1024.0

struct ParticleSplatPush {
  uint64_t frameAddress[2];  // ViewFrame of each eye (the classification uses eye 0's size)
  uint64_t batchAddress;     // ParticleBatchInfo[batchCount]
  uint64_t argsAddress;      // VkDrawIndirectCommand per batch: instanceCount = its live records
  uint64_t accumAddress;     // the accumulators (float or fixed point, MIRAGE_SPLAT_CHANNELS per pixel)
  uint64_t largeAddress;     // uint[total]: global records left to the billboards
  uint64_t largeArgsAddress; // VkDrawIndirectCommand of the billboards' draw: instanceCount counts them
  uint total;                // record slots over all batches
  uint batchCount;
  uint eyes;             // 1, or 2: side by side, eye e's pixels at x + e * eyeWidth
  uint eyeWidth;         // pixels
  uint height;           // pixels
  float belowPixels;     // billboard edges under this many pixels are splatted
  uint fixedPoint;       // 1: the accumulators are fixed point (resolve, tile pass)
  uint phase;            // binned: MIRAGE_SPLAT_PHASE_*
  uint64_t binAddress;   // binned: the bins (uint[], MIRAGE_SPLAT_BIN_HEADER)
  uint64_t entryAddress; // binned: uvec4[entryRoom] (MIRAGE_SPLAT_ENTRY_BYTES each), listed by tile
  uint entryRoom;        // binned: entries the lists hold
  uint tilesX;           // binned: tiles per eye across (tile t = (eye * tilesY + y) * tilesX + x)
  uint tilesY;
  uint binSlotBits;      // binned: log2 of the count and scatter passes' table slots in use
  uint64_t tableAddress; // binned: each count workgroup's table for its scatter (MIRAGE_SPLAT_BIN_SLOTS uvec2)
};

#ifdef __cplusplus
static_assert(sizeof(ParticleSplatPush) == 128, "ParticleSplatPush layout: the guaranteed push constant size");
static_assert((1u << MIRAGE_SPLAT_BIN_SLOT_BITS) == MIRAGE_SPLAT_BIN_SLOTS, "bin slots: a power of two");
static_assert(sizeof(ParticleBatchInfo) == 32, "ParticleBatchInfo layout");
static_assert(sizeof(ParticleDrawPush) == 64, "ParticleDrawPush layout");
static_assert(sizeof(ParticleSortPush) == 120, "ParticleSortPush layout");
} // namespace mirage::shaderio
#endif

#endif
