// server/http/job_waits.h (the polls of GET /v1/jobs/{id}?wait=): the number of waiters is bounded, a waiter
// wakes on a notify that follows the generation it read (never misses one in between), and close() wakes every
// waiter and admits no new one. A wake-up that did not happen hangs the test (ctest's timeout fails it).
#include "server/http/job_waits.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <random>
#include <thread>
#include <vector>

namespace lipmap::server {
namespace {

using namespace std::chrono_literals;

const auto kNever = [] { return JobWaits::Clock::now() + 1h; };

TEST(JobWaits, PlacesAreBoundedAndGivenBack) {
  std::mt19937 rng(7);
  for (std::size_t max : {1u, 2u, 5u}) {
    JobWaits waits(max);
    std::vector<JobWaits::Place> held;
    for (int step = 0; step < 200; ++step) {
      if (rng() % 2 && !held.empty()) {
        held.pop_back();
      } else {
        JobWaits::Place p = waits.enter();
        EXPECT_EQ(static_cast<bool>(p), held.size() < max) << "max " << max << " held " << held.size();
        if (p) held.push_back(std::move(p));
      }
      EXPECT_EQ(waits.waiting(), held.size());
    }
  }
}

TEST(JobWaits, ANotifyAfterTheGenerationWasReadIsNeverMissed) {
  JobWaits waits(8);
  for (int round = 0; round < 50; ++round) {
    const std::uint64_t seen = waits.generation();
    // The notify may come before the waiter sleeps, or while it sleeps: it wakes either way.
    std::thread notifier([&waits, round] {
      if (round % 2) std::this_thread::sleep_for(1ms);
      waits.notify();
    });
    waits.sleep(seen, kNever());
    EXPECT_NE(waits.generation(), seen);
    notifier.join();
  }
}

TEST(JobWaits, SleepEndsAtItsDeadlineWithoutANotify) {
  JobWaits waits(1);
  const std::uint64_t seen = waits.generation();
  const auto until = JobWaits::Clock::now() + 20ms;
  waits.sleep(seen, until);
  EXPECT_GE(JobWaits::Clock::now(), until);
  EXPECT_EQ(waits.generation(), seen);
}

TEST(JobWaits, CloseWakesEveryWaiterAndAdmitsNoNewOne) {
  JobWaits waits(16);
  std::atomic<int> woke{0};
  std::vector<std::thread> waiters;
  for (int i = 0; i < 6; ++i)
    waiters.emplace_back([&] {
      JobWaits::Place place = waits.enter();
      ASSERT_TRUE(place);
      waits.sleep(waits.generation(), kNever());
      ++woke;
    });
  while (waits.waiting() < 6) std::this_thread::sleep_for(1ms);
  EXPECT_FALSE(waits.closed());
  waits.close();
  for (std::thread& t : waiters) t.join();
  EXPECT_EQ(woke.load(), 6);
  EXPECT_TRUE(waits.closed());
  EXPECT_FALSE(waits.enter());
  EXPECT_EQ(waits.waiting(), 0u);
  waits.sleep(waits.generation(), kNever());  // closed: returns at once
}

}  // namespace
}  // namespace lipmap::server
