// The bake journal (`<output>.journal`, bake/journal.h) that --resume reads. The fingerprint and
// unit count come from the input's own header (at most kMaxUnits units, as a bake's caller knows its
// count), so the entries are reached. What parseJournal accepts must hold complete entries of
// distinct units within the count, end at validBytes inside the input, and read the same through
// readJournal from a file; continued as the bake continues it (Journal::open with validBytes, which
// cuts a torn tail off, then one more entry) it must read as the same entries plus that one; written
// afresh by the writer it must read as the same entries. Rejections are one line.
#include <algorithm>
#include <cstring>

#include "fuzz_support.h"
#include "mirage/bake/journal.h"

using namespace mirage;

namespace {

constexpr uint32_t kMaxUnits = 1u << 16;
constexpr size_t kHeaderBytes = 20, kEntryHeaderBytes = 20;

bool sameEntries(const std::vector<bake::JournalEntry>& a, const std::vector<bake::JournalEntry>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                    [](const auto& x, const auto& y) { return x.unit == y.unit && x.bytes == y.bytes; });
}

uint64_t fileSize(const std::filesystem::path& path) { return std::filesystem::file_size(path); }

Result<bake::JournalContents> readBack(const std::filesystem::path& path, uint64_t print, uint32_t units,
                                       const char* what) {
  auto read = bake::readJournal(path.string(), print, units);
  if (!read) fuzz::fail(std::string(what) + " is rejected: " + read.error().message);
  fuzz::check(read->validBytes == fileSize(path), std::string(what) + " has bytes after its last entry");
  return read;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  uint64_t print = 0;
  uint32_t units = 0;
  if (size >= kHeaderBytes) std::memcpy(&print, data + 8, 8), std::memcpy(&units, data + 16, 4);
  units = std::min(units, kMaxUnits);
  const std::span<const uint8_t> bytes(data, size);
  auto parsed = bake::parseJournal(bytes, "in.journal", print, units);
  if (!parsed) {
    fuzz::checkOneLine(parsed.error());
    return 0;
  }
  const bake::JournalContents& j = *parsed;
  fuzz::check(j.validBytes >= kHeaderBytes && j.validBytes <= size, "validBytes outside the input");
  if (size - j.validBytes >= kEntryHeaderBytes) { // what follows must be a torn entry
    uint64_t length = 0;
    std::memcpy(&length, data + j.validBytes + 4, 8);
    fuzz::check(length > size - j.validBytes - kEntryHeaderBytes, "a whole entry after validBytes");
  }
  std::vector<bool> seen(units);
  uint64_t entryBytes = 0;
  for (const bake::JournalEntry& e : j.entries) {
    fuzz::check(e.unit < units, "an entry's unit is outside the count");
    fuzz::check(!seen[e.unit], "a unit is returned twice");
    seen[e.unit] = true;
    entryBytes += kEntryHeaderBytes + e.bytes.size();
  }
  fuzz::check(kHeaderBytes + entryBytes <= j.validBytes, "the entries hold more bytes than validBytes");

  // The same from a file.
  const auto path = fuzz::writeScratch("in.journal", bytes);
  auto read = bake::readJournal(path.string(), print, units);
  if (!read) fuzz::fail("readJournal rejects what parseJournal accepts: " + read.error().message);
  fuzz::check(read->validBytes == j.validBytes && sameEntries(read->entries, j.entries),
              "readJournal and parseJournal disagree");

  // Continued after validBytes with one entry: a unit not yet journaled (or, all taken, a repeat,
  // which the reader skips).
  uint32_t next = 0;
  while (next < units && seen[next]) ++next;
  const std::span<const uint8_t> more = bytes.first(std::min<size_t>(size, 64));
  {
    auto journal = bake::Journal::open(path.string(), print, units, j.validBytes);
    if (!journal) fuzz::fail("a read journal cannot be continued: " + journal.error().message);
    if (units > 0) {
      Status appended = journal->append(next < units ? next : 0, more);
      if (!appended) fuzz::fail("cannot append to a continued journal: " + appended.error().message);
    }
  }
  auto continued = readBack(path, print, units, "a continued journal");
  std::vector<bake::JournalEntry> expected = j.entries;
  if (next < units) expected.push_back({next, std::vector<uint8_t>(more.begin(), more.end())});
  fuzz::check(sameEntries(continued->entries, expected), "a continued journal reads other entries");

  // Written afresh.
  const auto fresh = fuzz::scratchDir() / "fresh.journal";
  {
    auto journal = bake::Journal::open(fresh.string(), print, units, 0);
    if (!journal) fuzz::fail("cannot start a journal: " + journal.error().message);
    for (const bake::JournalEntry& e : j.entries) {
      Status appended = journal->append(e.unit, e.bytes);
      if (!appended) fuzz::fail("cannot append: " + appended.error().message);
    }
  }
  auto again = readBack(fresh, print, units, "a rewritten journal");
  fuzz::check(sameEntries(again->entries, j.entries), "a rewritten journal reads other entries");
  fuzz::check(again->validBytes == kHeaderBytes + entryBytes, "a rewritten journal's size differs");
  return 0;
}
