// The distributed bake's parts (docs/bake.md): the journal (round trip, a torn last entry dropped,
// another bake's journal and damaged entries refused), the scheduler (every unit's bytes in unit
// order, resumed units not baked again, a unit's error reaching every rank with the journal
// deleted), BakedMesh's exact round trip, and the scheduled LOD bake writing the same .mrg bytes as
// lod::bakeLodAsset. The Distributed.* tests are collective: ctest also runs them under
// `mpirun -np 4` (bake.mpi) when Mirage is built with MPI; alone they run in a world of one.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "mirage/bake/journal.h"
#include "mirage/bake/lod_bake.h"
#include "mirage/bake/scheduler.h"
#include "mirage/io/generate.h"
#include "mirage/lod/baked_mesh.h"
#include "bake_test_util.h"
#include "test_support.h"

using namespace mirage;
namespace fs = std::filesystem;

namespace {

std::vector<uint8_t> unitBytes(uint32_t unit) { // distinct sizes and contents per unit
  std::vector<uint8_t> b(100 + unit * 37);
  for (size_t i = 0; i < b.size(); ++i) b[i] = uint8_t(i * 31 + unit * 7);
  return b;
}

} // namespace

TEST(Journal, RoundTripTornEntryAndOtherBakes) {
  fs::path dir = test::tempDir("journal");
  std::string path = (dir / "a.journal").string();
  {
    auto j = bake::Journal::open(path, 42, 5, 0);
    ASSERT_TRUE(j.ok()) << j.error().message;
    for (uint32_t u : {3u, 1u, 4u}) ASSERT_TRUE(j->append(u, unitBytes(u)).ok());
  }
  auto read = bake::readJournal(path, 42, 5);
  ASSERT_TRUE(read.ok()) << read.error().message;
  ASSERT_EQ(read->entries.size(), 3u);
  EXPECT_EQ(read->entries[0].unit, 3u);
  EXPECT_EQ(read->entries[1].bytes, unitBytes(1));
  EXPECT_EQ(read->validBytes, fs::file_size(path));

  // A process killed while writing: the last entry is cut short and dropped.
  fs::resize_file(path, fs::file_size(path) - 10);
  auto torn = bake::readJournal(path, 42, 5);
  ASSERT_TRUE(torn.ok());
  EXPECT_EQ(torn->entries.size(), 2u);
  {
    auto j = bake::Journal::open(path, 42, 5, torn->validBytes); // continued after the cut
    ASSERT_TRUE(j.ok());
    ASSERT_TRUE(j->append(0, unitBytes(0)).ok());
  }
  auto continued = bake::readJournal(path, 42, 5);
  ASSERT_TRUE(continued.ok());
  ASSERT_EQ(continued->entries.size(), 3u);
  EXPECT_EQ(continued->entries[2].bytes, unitBytes(0));

  EXPECT_FALSE(bake::readJournal(path, 43, 5).ok()); // another fingerprint
  EXPECT_FALSE(bake::readJournal(path, 42, 6).ok()); // another unit count
  auto bytes = test::fileBytes(path);
  bytes[bytes.size() - 3] ^= 1; // damaged inside the last entry's bytes
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  auto damaged = bake::readJournal(path, 42, 5);
  ASSERT_FALSE(damaged.ok());
  EXPECT_NE(damaged.error().message.find("damaged"), std::string::npos);
  EXPECT_EQ(bake::parseJournal(bytes, path, 42, 5).error().message, damaged.error().message); // the file's bytes
  EXPECT_TRUE(bake::readJournal((dir / "missing").string(), 1, 1)->entries.empty());
  EXPECT_FALSE(bake::parseJournal({}, path, 1, 1).ok()); // an empty file is not a journal
  fs::remove_all(dir);
}

TEST(Scheduler, ResumeBakesOnlyMissingUnits) {
  fs::path dir = test::tempDir("resume");
  bake::World alone = std::move(bake::World::join()).value(); // no MPI launcher: a world of one
  ASSERT_EQ(alone.size(), 1);
  bake::UnitPlan plan{{5, 1, 9, 2, 7, 3}, 7, (dir / "j").string(), false};
  {
    auto j = bake::Journal::open(plan.journal, 7, 6, 0);
    ASSERT_TRUE(j->append(2, unitBytes(2)).ok() && j->append(4, unitBytes(4)).ok());
  }
  plan.resume = true;
  std::vector<uint32_t> baked;
  bake::ScheduleReport report;
  auto out = bake::runUnits(
      alone, plan, {},
      [&](uint32_t u, std::span<const uint8_t>) -> Result<std::vector<uint8_t>> {
        baked.push_back(u);
        return unitBytes(u);
      },
      &report);
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ(out->size(), 6u);
  for (uint32_t u = 0; u < 6; ++u) EXPECT_EQ((*out)[u], unitBytes(u));
  EXPECT_EQ(baked, (std::vector<uint32_t>{0, 5, 3, 1})); // the rest, largest first
  EXPECT_EQ(report.resumedUnits, 2u);
  EXPECT_EQ(report.ranks[0].units, baked);
  EXPECT_EQ(bake::readJournal(plan.journal, 7, 6)->entries.size(), 6u); // kept until the output is written
  bake::removeJournal(alone, plan);
  EXPECT_FALSE(fs::exists(plan.journal));
  fs::remove_all(dir);
}

TEST(Distributed, EveryUnitOnceInUnitOrder) {
  const bake::World& w = test::world();
  bake::UnitPlan plan;
  for (uint32_t u = 0; u < 40; ++u) plan.costs.push_back(u % 7);
  bake::ScheduleReport report;
  // Each unit's input (made on rank 0) is its expected bytes reversed: the baker turns it back.
  auto input = [](uint32_t u) {
    std::vector<uint8_t> b = unitBytes(u);
    std::reverse(b.begin(), b.end());
    return b;
  };
  auto bake = [](uint32_t, std::span<const uint8_t> in) -> Result<std::vector<uint8_t>> {
    return std::vector<uint8_t>(in.rbegin(), in.rend());
  };
  auto out = bake::runUnits(w, plan, input, bake, &report);
  ASSERT_TRUE(out.ok()) << out.error().message;
  if (!w.root()) {
    EXPECT_TRUE(out->empty());
    return;
  }
  ASSERT_EQ(out->size(), 40u);
  for (uint32_t u = 0; u < 40; ++u) EXPECT_EQ((*out)[u], unitBytes(u));
  ASSERT_EQ(report.ranks.size(), size_t(w.size()));
  std::vector<int> count(40);
  for (const bake::RankReport& r : report.ranks)
    for (uint32_t u : r.units) ++count[u];
  for (uint32_t u = 0; u < 40; ++u) EXPECT_EQ(count[u], 1) << "unit " << u;
}

// Lanes: three bakers per rank, each on its own thread (runUnits with a span of bakers): every unit
// once, in unit order, and (in a world of one) the lanes really bake at the same time.
TEST(Distributed, LanesBakeAtOnceEveryUnitOnce) {
  const bake::World& w = test::world();
  bake::UnitPlan plan;
  for (uint32_t u = 0; u < 30; ++u) plan.costs.push_back(1 + u % 4);
  std::atomic<int> active{0}, most{0};
  auto bake = [&](uint32_t u, std::span<const uint8_t>) -> Result<std::vector<uint8_t>> {
    int now = ++active;
    for (int seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5)); // long enough for the other lanes to start
    --active;
    return unitBytes(u);
  };
  std::vector<bake::UnitBaker> lanes(3, bake);
  bake::ScheduleReport report;
  auto out = bake::runUnits(w, plan, {}, lanes, &report);
  ASSERT_TRUE(out.ok()) << out.error().message;
  // Alone, this rank has every unit for its three lanes (under mpirun another rank's lanes may take
  // them all).
  if (w.size() == 1) {
    EXPECT_GE(most.load(), 2);
  }
  if (!w.root()) return;
  ASSERT_EQ(out->size(), 30u);
  for (uint32_t u = 0; u < 30; ++u) EXPECT_EQ((*out)[u], unitBytes(u));
  std::vector<int> count(30);
  for (const bake::RankReport& r : report.ranks)
    for (uint32_t u : r.units) ++count[u];
  for (uint32_t u = 0; u < 30; ++u) EXPECT_EQ(count[u], 1) << "unit " << u;
}

TEST(Distributed, UnitErrorReachesEveryRank) {
  const bake::World& w = test::world();
  fs::path dir = test::tempDir("error"); // each rank names its own; only rank 0's journal is written
  bake::UnitPlan plan{std::vector<uint64_t>(24, 1), 3, (dir / "j").string(), false};
  auto out = bake::runUnits(w, plan, {}, [](uint32_t u, std::span<const uint8_t>) -> Result<std::vector<uint8_t>> {
    if (u == 17) return Error{"scene.obj: mesh 17: broken"};
    return unitBytes(u);
  });
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().message, "scene.obj: mesh 17: broken");
  EXPECT_FALSE(fs::exists(plan.journal)); // nothing to resume from a bake that cannot succeed
  // The same with two lanes per rank: the error stops every lane of every rank.
  bake::UnitBaker failing = [](uint32_t u, std::span<const uint8_t>) -> Result<std::vector<uint8_t>> {
    if (u == 5) return Error{"scene.obj: mesh 5: broken"};
    return unitBytes(u);
  };
  std::vector<bake::UnitBaker> lanes(2, failing);
  auto laned = bake::runUnits(w, plan, {}, lanes);
  ASSERT_FALSE(laned.ok());
  EXPECT_EQ(laned.error().message, "scene.obj: mesh 5: broken");
  fs::remove_all(dir);
}

TEST(Distributed, LodBakeEqualsSingleProcessBake) {
  const bake::World& w = test::world();
  auto scene = io::generateScene("city", 3, 2);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_GT(scene->meshes.size(), 3u);
  lod::BuildConfig config;
  config.clusterTriangles = 64;
  // Only rank 0 has the scene: it sends every other rank the meshes it bakes.
  auto distributed = bake::bakeLodAsset(w, w.root() ? *scene : Scene{}, config, {});
  ASSERT_TRUE(distributed.ok()) << distributed.error().message;
  if (!w.root()) return;
  config.threads = 1; // a DAG does not depend on the thread count
  auto single = lod::bakeLodAsset(*scene, config);
  ASSERT_TRUE(single.ok());
  fs::path dir = test::tempDir("lod");
  ASSERT_TRUE(lod::saveLodAsset((dir / "a.mrg").string(), *distributed).ok());
  ASSERT_TRUE(lod::saveLodAsset((dir / "b.mrg").string(), *single).ok());
  EXPECT_EQ(test::fileBytes(dir / "a.mrg"), test::fileBytes(dir / "b.mrg"));
  // The unit's bytes carry every field exactly (timings included).
  for (size_t m = 0; m < single->dags.size(); ++m) {
    lod::BakedMesh mesh{single->dags[m], single->sourceClusters[m]};
    std::vector<uint8_t> bytes = lod::encodeBakedMesh(mesh);
    auto back = lod::decodeBakedMesh(bytes, "unit");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(lod::encodeBakedMesh(*back), bytes);
    EXPECT_EQ(back->dag.levels.back().seconds, mesh.dag.levels.back().seconds);
    bytes.pop_back();
    EXPECT_FALSE(lod::decodeBakedMesh(bytes, "unit").ok());
  }
  fs::remove_all(dir);
}
