#pragma once
// The journal of a bake: every finished work unit's bytes, appended by rank 0 as it arrives, in a
// file beside the output (`<output>.journal`), so that `--resume` after a rank or the whole job died
// bakes only the units it lacks. Written through to the operating system after each unit (a killed
// process loses nothing; a host crash may lose the last units, which are baked again).
//
// Layout (little-endian): header = "MRGJ", u32 version, u64 fingerprint of the bake (its inputs and
// settings), u32 unit count; then entries = u32 unit, u64 length, u64 XXH3 of the bytes, the bytes.
// A torn last entry (the process died while writing it) is dropped on reading. docs/bake.md.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::bake {

struct JournalEntry {
  uint32_t unit = 0;
  std::vector<uint8_t> bytes;
};

struct JournalContents {
  std::vector<JournalEntry> entries; // complete entries in the order written (a unit at most once)
  uint64_t validBytes = 0;           // bytes up to the end of the last complete entry (0: no journal)
};

// The journal at `path` of the bake with this fingerprint and unit count. A missing file is an
// empty journal. Errors: not a journal, or one of another bake (other inputs or settings).
Result<JournalContents> readJournal(const std::string& path, uint64_t fingerprint, uint32_t units);
// What readJournal makes of a journal's bytes (`path` names them in errors); an empty span is not a
// journal (a missing file is readJournal's case).
Result<JournalContents> parseJournal(std::span<const uint8_t> bytes, const std::string& path, uint64_t fingerprint,
                                     uint32_t units);

class Journal {
public:
  // Starts a journal at `path` (replacing any file there) or, with keepBytes > 0, continues the one
  // readJournal read, cutting a torn last entry off.
  static Result<Journal> open(const std::string& path, uint64_t fingerprint, uint32_t units, uint64_t keepBytes);
  Journal(Journal&& other) noexcept;
  Journal& operator=(Journal&&) = delete;
  ~Journal(); // closes; the file stays (remove() deletes it)

  Status append(uint32_t unit, std::span<const uint8_t> bytes);
  // Closes and deletes the file: the output is written, or the bake failed for good.
  void remove();
  const std::string& path() const { return path_; }

private:
  Journal(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  std::string path_;
  int fd_ = -1;
};

} // namespace mirage::bake
