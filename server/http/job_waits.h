// GET /v1/jobs/{id}?wait=S: a poll that waits, at most S seconds, for the job to end (docs/api.md), so that a
// client learns of the end at once instead of polling every few milliseconds. A waiter sleeps until a job this
// process ran ends (notify), its recheck time passes (a job run by another replica of the shared queue ends
// without telling this one), its own deadline, or the service starts draining (close). At most `max_waiters`
// wait at once, so waiting polls cannot take every connection; beyond that a poll answers at once.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>

namespace lipmap::server {

class JobWaits {
public:
  using Clock = std::chrono::steady_clock;
  explicit JobWaits(std::size_t max_waiters) : max_waiters_(max_waiters) {}
  JobWaits(const JobWaits&) = delete;
  JobWaits& operator=(const JobWaits&) = delete;

  // One waiter's place, held for one poll; false when every place is taken or the service is draining.
  class Place {
  public:
    Place() = default;
    explicit Place(JobWaits* waits) : waits_(waits) {}
    Place(Place&& other) noexcept : waits_(other.waits_) { other.waits_ = nullptr; }
    Place& operator=(Place&&) = delete;
    Place(const Place&) = delete;
    ~Place();
    explicit operator bool() const { return waits_ != nullptr; }

  private:
    JobWaits* waits_ = nullptr;
  };
  Place enter();

  // Changes at every notify(): read it before looking at the job, then sleep(seen, ...) cannot miss an end
  // that happened in between.
  std::uint64_t generation() const;
  // Until the generation differs from `seen`, `until` passes, or close().
  void sleep(std::uint64_t seen, Clock::time_point until);
  // A job of this process reached a final state.
  void notify();
  // Draining: every waiter answers now and no new one waits.
  void close();
  bool closed() const;
  std::size_t waiting() const;

private:
  const std::size_t max_waiters_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::uint64_t generation_ = 0;
  std::size_t waiting_ = 0;
  bool closed_ = false;
};

}  // namespace lipmap::server
