#include "mirage/bake/pvs_bake.h"

#include <xxhash.h>

#include "mirage/asset/bytes.h"

namespace mirage::bake {

namespace {

constexpr uint32_t kCellPvsMagic = 0x53565043; // "CPVS"

// A cell's PVS as bytes: the triangles and every statistic bit for bit (for --json).
std::vector<uint8_t> encodeCellPvs(const vis::CellPvs& pvs) {
  const vis::PvsStats& s = pvs.stats;
  asset::ByteWriter w;
  w.write(kCellPvsMagic);
  w.writeArray(std::span<const uint32_t>(pvs.triangles));
  w.write(s.rays), w.write(s.randomRays), w.write(s.absRays), w.write(s.rsRays), w.write(s.discontinuities);
  w.write(s.iterations), w.write(s.seconds), w.write(s.traceSeconds), w.write(s.randomSeconds);
  w.write(s.randomTraceSeconds), w.write(s.absSeconds), w.write(s.absTraceSeconds), w.write(s.rsSeconds);
  // Which rays the backend made: bit 0 random, bit 1 border and reverse.
  w.write(s.rsTraceSeconds), w.write(uint8_t(uint8_t(s.generatedRandomRays) | uint8_t(s.generatedExploreRays) << 1));
  return w.take();
}

Result<vis::CellPvs> decodeCellPvs(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  vis::CellPvs pvs;
  vis::PvsStats& s = pvs.stats;
  uint32_t magic = 0;
  uint8_t generated = 0;
  r.read(magic), r.readArray(pvs.triangles);
  r.read(s.rays), r.read(s.randomRays), r.read(s.absRays), r.read(s.rsRays), r.read(s.discontinuities);
  r.read(s.iterations), r.read(s.seconds), r.read(s.traceSeconds), r.read(s.randomSeconds);
  r.read(s.randomTraceSeconds), r.read(s.absSeconds), r.read(s.absTraceSeconds), r.read(s.rsSeconds);
  r.read(s.rsTraceSeconds), r.read(generated);
  if (Status st = r.finish(); !st) return st.error();
  if (magic != kCellPvsMagic) return makeError(where, "not a cell's PVS");
  s.generatedRandomRays = (generated & 1) != 0;
  s.generatedExploreRays = (generated & 2) != 0;
  return pvs;
}

} // namespace

uint64_t pvsFingerprint(const std::string& settings, const std::vector<vis::ViewCell>& cells, uint64_t sceneTriangles) {
  asset::ByteWriter w;
  w.writeString("mirage pvs: CellPvs 1");
  w.writeString(settings);
  w.writeString(vis::viewCellsToJson(cells));
  w.write(sceneTriangles);
  return XXH3_64bits(w.data().data(), w.size());
}

Result<std::vector<vis::CellPvs>> bakeCellPvs(const World& world, size_t cells, uint64_t fingerprint,
                                              std::span<const CellBaker> bakers, const BakeRun& run,
                                              ScheduleReport* report, const UnitProgress& progress) {
  UnitPlan plan;
  if (world.root()) {
    plan.costs.assign(cells, 1); // unknown until baked: the queue balances them anyway
    plan.fingerprint = fingerprint;
    plan.journal = run.journal;
    plan.resume = run.resume;
  }
  std::vector<UnitBaker> units;
  for (const CellBaker& bake : bakers)
    units.push_back([&bake](uint32_t cell, std::span<const uint8_t>) -> Result<std::vector<uint8_t>> {
      return encodeCellPvs(bake(cell));
    });
  auto baked = runUnits(world, plan, {}, units, report, progress);
  if (!baked) return baked.error();
  std::vector<vis::CellPvs> out;
  for (const std::vector<uint8_t>& bytes : *baked) {
    auto pvs = decodeCellPvs(bytes, run.journal.empty() ? "cell PVS" : run.journal);
    if (!pvs) return pvs.error();
    out.push_back(std::move(pvs).value());
  }
  return out;
}

} // namespace mirage::bake
