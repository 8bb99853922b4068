#include "mirage/bake/scheduler.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <numeric>
#include <optional>
#include <thread>

#include "mirage/bake/journal.h"

namespace mirage::bake {

namespace {

// Messages between rank 0 and the others. A worker says Ready once (with its lane count), then
// answers each Assign with a Result or a Failure; rank 0 answers each request (every lane of the
// Ready, every Result and Failure) with the next Assign, or Stop when no unit is left (or a unit
// failed).
enum Tag : int { kReady = 1, kResult = 2, kFailure = 3, kAssign = 4, kStop = 5 };

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

template <class T> void put(std::vector<uint8_t>& out, const T& v) {
  size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &v, sizeof(T));
}
template <class T> T get(std::span<const uint8_t> in, size_t at) {
  T v{};
  if (in.size() >= at + sizeof(T)) std::memcpy(&v, in.data() + at, sizeof(T));
  return v;
}

// A unit baked, as the reply to rank 0 says it: Result (unit, seconds, bytes) or Failure (unit, message).
std::pair<int, std::vector<uint8_t>> bakeAssigned(const UnitBaker& bake, std::span<const uint8_t> assign) {
  uint32_t unit = get<uint32_t>(assign, 0);
  auto t0 = Clock::now();
  auto baked = bake(unit, assign.subspan(std::min<size_t>(4, assign.size())));
  std::vector<uint8_t> reply;
  put(reply, unit);
  if (!baked) {
    reply.insert(reply.end(), baked.error().message.begin(), baked.error().message.end());
    return {kFailure, std::move(reply)}; // rank 0 answers Stop
  }
  put(reply, secondsSince(t0));
  reply.reserve(reply.size() + baked->size());
  reply.insert(reply.end(), baked->begin(), baked->end());
  return {kResult, std::move(reply)};
}

// A worker rank: one thread per baker (lane), each baking the units it is handed until told to
// stop. Ready says how many lanes ask; rank 0 answers each request (the lanes of Ready, then
// every Result or Failure) with an Assign or a Stop, so once every lane got its Stop, every result
// has been sent. Only this thread talks to the other ranks.
Status work(const World& world, std::span<const UnitBaker> bakers) {
  const uint32_t lanes = uint32_t(bakers.size());
  std::vector<uint8_t> ready;
  put(ready, lanes);
  world.send(0, kReady, ready);
  std::mutex mutex;
  std::condition_variable wake;
  std::deque<std::optional<std::vector<uint8_t>>> assigned; // nullopt: a lane stops
  std::deque<std::pair<int, std::vector<uint8_t>>> replies;
  std::vector<std::thread> threads;
  for (uint32_t lane = 0; lane < lanes; ++lane)
    threads.emplace_back([&, lane] {
      for (;;) {
        std::optional<std::vector<uint8_t>> assign;
        {
          std::unique_lock lock(mutex);
          wake.wait(lock, [&] { return !assigned.empty(); });
          assign = std::move(assigned.front());
          assigned.pop_front();
        }
        if (!assign) return;
        auto reply = bakeAssigned(bakers[lane], *assign);
        std::lock_guard lock(mutex);
        replies.push_back(std::move(reply));
        wake.notify_all();
      }
    });
  for (uint32_t stops = 0; stops < lanes;) {
    std::unique_lock lock(mutex);
    while (!replies.empty()) {
      auto reply = std::move(replies.front());
      replies.pop_front();
      lock.unlock();
      world.send(0, reply.first, reply.second);
      lock.lock();
    }
    lock.unlock();
    if (auto e = world.poll()) {
      std::vector<uint8_t> message = world.receive(*e);
      lock.lock();
      if (e->tag == kStop)
        assigned.push_back(std::nullopt), ++stops;
      else
        assigned.push_back(std::move(message));
      wake.notify_all();
      continue;
    }
    // Woken at once by a lane's reply; rank 0's messages are polled every millisecond.
    lock.lock();
    if (replies.empty()) wake.wait_for(lock, std::chrono::milliseconds(1));
  }
  for (std::thread& t : threads) t.join();
  return Ok{};
}

// Rank 0: the queue, its own baking threads (one per lane), the journal and the gathered bytes.
class Coordinator {
public:
  Coordinator(const World& world, const UnitPlan& plan, const UnitInput& input, std::span<const UnitBaker> bakers,
              const UnitProgress& progress)
      : world_(world), plan_(plan), input_(input), bakers_(bakers), progress_(progress), results_(plan.costs.size()),
        done_(plan.costs.size()) {
    report_.ranks.resize(size_t(world.size()));
    totalCost_ = std::accumulate(plan.costs.begin(), plan.costs.end(), uint64_t(0));
  }

  Status run() {
    auto t0 = Clock::now();
    if (Status s = openJournal(); !s) fail(s.error());
    // Largest first (ties: unit order), so the last units to finish are small.
    std::vector<uint32_t> order;
    for (uint32_t u = 0; u < results_.size(); ++u)
      if (!done_[u]) order.push_back(u);
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return plan_.costs[a] > plan_.costs[b]; });
    queue_.assign(order.begin(), order.end());
    if (progress_) progress_(doneUnits_, results_.size(), doneCost_, totalCost_);

    std::vector<std::thread> local;
    for (const UnitBaker& bake : bakers_) local.emplace_back([this, &bake] { bakeLocally(bake); });
    // Workers that have not said Ready yet, and requests of the others not answered by a Stop.
    int unannounced = world_.size() - 1, open = 0;
    for (;;) {
      bool busy = false;
      while (auto e = world_.poll()) { // workers' messages
        busy = true;
        uint32_t requests = serveWorker(*e);
        if (e->tag == kReady) --unannounced, open += int(requests);
        for (uint32_t r = 0; r < requests; ++r) {
          if (auto unit = take()) {
            std::vector<uint8_t> assign;
            put(assign, *unit);
            if (input_) {
              std::vector<uint8_t> in = input_(*unit);
              assign.insert(assign.end(), in.begin(), in.end());
            }
            world_.send(e->source, kAssign, assign);
          } else {
            world_.send(e->source, kStop, {});
            --open;
          }
        }
      }
      std::unique_lock lock(mutex_);
      while (!localDone_.empty()) { // this rank's own units
        busy = true;
        LocalResult r = std::move(localDone_.front());
        localDone_.pop_front();
        lock.unlock();
        if (r.bytes)
          accept(0, r.unit, std::move(*r.bytes), r.seconds);
        else
          fail(r.bytes.error());
        lock.lock();
      }
      if (localFinished_ == bakers_.size() && unannounced == 0 && open == 0) break;
      // Woken at once by the local thread; remote messages are polled every millisecond.
      if (!busy) wake_.wait_for(lock, std::chrono::milliseconds(1));
    }
    for (std::thread& t : local) t.join();
    report_.seconds = secondsSince(t0);
    if (failure_) {
      if (journal_) journal_->remove();
      return *failure_;
    }
    return Ok{};
  }

  std::vector<std::vector<uint8_t>> takeResults() { return std::move(results_); }
  ScheduleReport& report() { return report_; }

private:
  struct LocalResult {
    uint32_t unit = 0;
    Result<std::vector<uint8_t>> bytes;
    double seconds = 0.0;
  };

  Status openJournal() {
    if (plan_.journal.empty()) return Ok{};
    uint32_t units = uint32_t(results_.size());
    uint64_t keep = 0;
    if (plan_.resume) {
      auto read = readJournal(plan_.journal, plan_.fingerprint, units);
      if (!read) return read.error();
      for (JournalEntry& e : read->entries) {
        results_[e.unit] = std::move(e.bytes);
        done_[e.unit] = true;
        ++doneUnits_, doneCost_ += plan_.costs[e.unit];
      }
      report_.resumedUnits = read->entries.size();
      keep = read->validBytes;
    }
    auto journal = Journal::open(plan_.journal, plan_.fingerprint, units, keep);
    if (!journal) return journal.error();
    journal_.emplace(std::move(journal).value());
    return Ok{};
  }

  std::optional<uint32_t> take() {
    std::lock_guard lock(mutex_);
    if (failure_ || queue_.empty()) return std::nullopt;
    uint32_t u = queue_.front();
    queue_.pop_front();
    return u;
  }

  void fail(const Error& e) {
    std::lock_guard lock(mutex_);
    if (!failure_) failure_ = e; // the first error is the one reported
  }

  void bakeLocally(const UnitBaker& bake) {
    while (auto unit = take()) {
      auto t0 = Clock::now();
      std::vector<uint8_t> in = input_ ? input_(*unit) : std::vector<uint8_t>();
      LocalResult r{*unit, bake(*unit, in), 0.0};
      r.seconds = secondsSince(t0);
      std::lock_guard lock(mutex_);
      localDone_.push_back(std::move(r));
      wake_.notify_one();
    }
    std::lock_guard lock(mutex_);
    ++localFinished_;
    wake_.notify_one();
  }

  // Takes in a worker's message; returns the requests it makes (the lanes of a Ready, else one).
  uint32_t serveWorker(const Envelope& e) {
    std::vector<uint8_t> message = world_.receive(e);
    uint32_t unit = get<uint32_t>(message, 0);
    if (e.tag == kReady) return std::max<uint32_t>(1, unit); // the worker's lanes
    if (e.tag == kFailure) {
      fail(Error{std::string(message.begin() + 4, message.end())});
    } else if (e.tag == kResult) {
      double seconds = get<double>(message, 4);
      message.erase(message.begin(), message.begin() + 12);
      accept(e.source, unit, std::move(message), seconds);
    }
    return e.tag == kResult || e.tag == kFailure ? 1 : 0;
  }

  void accept(int rank, uint32_t unit, std::vector<uint8_t> bytes, double seconds) {
    if (journal_)
      if (Status s = journal_->append(unit, bytes); !s) fail(s.error());
    RankReport& r = report_.ranks[size_t(rank)];
    r.units.push_back(unit);
    r.busySeconds += seconds;
    results_[unit] = std::move(bytes);
    done_[unit] = true;
    ++doneUnits_, doneCost_ += plan_.costs[unit];
    if (progress_) progress_(doneUnits_, results_.size(), doneCost_, totalCost_);
  }

  const World& world_;
  const UnitPlan& plan_;
  const UnitInput& input_;
  std::span<const UnitBaker> bakers_;
  const UnitProgress& progress_;
  std::vector<std::vector<uint8_t>> results_;
  std::vector<bool> done_;
  size_t doneUnits_ = 0;
  uint64_t doneCost_ = 0, totalCost_ = 0;
  std::optional<Journal> journal_;
  ScheduleReport report_;
  // Shared with the local baking thread.
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<uint32_t> queue_;
  std::deque<LocalResult> localDone_;
  size_t localFinished_ = 0; // local baking threads done
  std::optional<Error> failure_;
};

} // namespace

Result<std::vector<std::vector<uint8_t>>> runUnits(const World& world, const UnitPlan& plan, const UnitInput& input,
                                                   std::span<const UnitBaker> bakers, ScheduleReport* report,
                                                   const UnitProgress& progress) {
  if (bakers.empty()) return Error{"bake: no baker"};
  if (!world.root()) {
    Status mine = work(world, bakers);
    if (Status all = world.agree(mine); !all) return all.error();
    return std::vector<std::vector<uint8_t>>{};
  }
  Coordinator c(world, plan, input, bakers, progress);
  Status mine = c.run();
  if (Status all = world.agree(mine); !all) return all.error();
  if (report) *report = std::move(c.report());
  return c.takeResults();
}

Result<std::vector<std::vector<uint8_t>>> runUnits(const World& world, const UnitPlan& plan, const UnitInput& input,
                                                   const UnitBaker& bake, ScheduleReport* report,
                                                   const UnitProgress& progress) {
  return runUnits(world, plan, input, std::span<const UnitBaker>(&bake, 1), report, progress);
}

void removeJournal(const World& world, const UnitPlan& plan) {
  if (world.root() && !plan.journal.empty()) ::unlink(plan.journal.c_str());
}

} // namespace mirage::bake
