#include "mirage/core/temp_files.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <mutex>

namespace mirage {

namespace {

constexpr int kSlots = 64;
constexpr size_t kPathBytes = 4096;

// state: 0 free, 1 being filled, 2 a path the handler removes.
struct Slot {
  std::atomic<int> state{0};
  char path[kPathBytes];
};
Slot gSlots[kSlots];
std::once_flag gInstalled;

extern "C" void removeTempFilesAndDie(int sig) {
  for (Slot& s : gSlots)
    if (s.state.load(std::memory_order_acquire) == 2) ::unlink(s.path);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

void installHandlers() {
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction current {};
    if (::sigaction(sig, nullptr, &current) != 0 || current.sa_handler != SIG_DFL) continue;
    struct sigaction sa {};
    sa.sa_handler = removeTempFilesAndDie;
    sigemptyset(&sa.sa_mask);
    ::sigaction(sig, &sa, nullptr);
  }
}

} // namespace

TempFileGuard::TempFileGuard(const std::string& path) {
  std::call_once(gInstalled, installHandlers);
  if (path.empty() || path.size() >= kPathBytes) return;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (!gSlots[i].state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) continue;
    std::memcpy(gSlots[i].path, path.c_str(), path.size() + 1);
    gSlots[i].state.store(2, std::memory_order_release);
    slot_ = i;
    return;
  }
}

TempFileGuard& TempFileGuard::operator=(TempFileGuard&& other) noexcept {
  if (this != &other) {
    release();
    slot_ = other.slot_;
    other.slot_ = -1;
  }
  return *this;
}

void TempFileGuard::release() {
  if (slot_ < 0) return;
  gSlots[slot_].state.store(0, std::memory_order_release);
  slot_ = -1;
}

} // namespace mirage
