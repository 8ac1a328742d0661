// server/http/worker_pool.{h,cpp}: the bounded queue refuses at capacity, queued tasks can be taken out,
// close / wait_idle / join, and every accepted task runs exactly once whatever the number of submitting
// threads. Real threads throughout; tasks that must stay busy wait on a gate the test opens.
#include "server/http/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace lipmap::server {
namespace {

using namespace std::chrono_literals;

// Tasks wait on it until open().
class Gate {
public:
  void wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [&] { return open_; });
  }
  void open() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      open_ = true;
    }
    cv_.notify_all();
  }

private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
};

// Waits (at most 10 s) until pred holds.
template <class Pred>
bool eventually(Pred pred) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

TEST(WorkerPool, BoundedQueueRefusesBeyondCapacity) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 12; ++trial) {
    const std::size_t workers = 1 + rng() % 4, capacity = rng() % 6;
    WorkerPool pool(workers, capacity);
    EXPECT_EQ(pool.workers(), workers);
    EXPECT_EQ(pool.capacity(), capacity);
    Gate gate;
    std::atomic<int> ran{0};
    auto blocking = [&] { gate.wait(); ++ran; };
    for (std::size_t i = 0; i < workers; ++i) ASSERT_EQ(pool.submit(blocking), WorkerPool::Submit::accepted);
    ASSERT_TRUE(eventually([&] { return pool.busy() == workers; }));  // running tasks do not count
    for (std::size_t i = 0; i < capacity; ++i) ASSERT_EQ(pool.submit(blocking), WorkerPool::Submit::accepted);
    EXPECT_EQ(pool.queue_depth(), capacity);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(pool.submit(blocking), WorkerPool::Submit::queue_full);
    const int retry = pool.retry_after_seconds();
    EXPECT_GE(retry, 1);
    EXPECT_LE(retry, 60);
    gate.open();
    ASSERT_TRUE(pool.wait_idle(std::chrono::steady_clock::now() + 10s));
    EXPECT_EQ(ran.load(), static_cast<int>(workers + capacity));  // the refused ones never ran
    EXPECT_EQ(pool.submit([] {}), WorkerPool::Submit::accepted);  // room again
  }
}

TEST(WorkerPool, RemoveTakesOnlyQueuedTasks) {
  WorkerPool pool(1, 10);
  Gate gate;
  std::atomic<bool> first_running{false};
  std::uint64_t running_ticket = 0;
  ASSERT_EQ(pool.submit([&] { first_running = true; gate.wait(); }, &running_ticket), WorkerPool::Submit::accepted);
  ASSERT_TRUE(eventually([&] { return first_running.load(); }));
  std::vector<std::uint64_t> tickets(10);
  std::vector<std::atomic<int>> runs(10);
  for (int i = 0; i < 10; ++i)
    ASSERT_EQ(pool.submit([&runs, i] { ++runs[i]; }, &tickets[i]), WorkerPool::Submit::accepted);
  EXPECT_EQ(std::set<std::uint64_t>(tickets.begin(), tickets.end()).size(), 10u);  // distinct tickets
  EXPECT_EQ(pool.submit([] {}), WorkerPool::Submit::queue_full);
  EXPECT_FALSE(pool.remove(running_ticket));  // taken by a worker already
  std::set<int> removed;
  for (int i = 0; i < 10; i += 3) {
    EXPECT_TRUE(pool.remove(tickets[i]));
    EXPECT_FALSE(pool.remove(tickets[i]));  // once
    removed.insert(i);
  }
  EXPECT_EQ(pool.queue_depth(), 10 - removed.size());
  EXPECT_EQ(pool.submit([] {}), WorkerPool::Submit::accepted);  // a removed task's place is free at once
  gate.open();
  ASSERT_TRUE(pool.wait_idle(std::chrono::steady_clock::now() + 10s));
  for (int i = 0; i < 10; ++i) EXPECT_EQ(runs[i].load(), removed.count(i) ? 0 : 1) << i;
}

TEST(WorkerPool, CloseWaitIdleAndJoin) {
  WorkerPool pool(2, 8);
  Gate gate;
  std::atomic<int> ran{0};
  for (int i = 0; i < 6; ++i) ASSERT_EQ(pool.submit([&] { gate.wait(); ++ran; }), WorkerPool::Submit::accepted);
  pool.close();
  EXPECT_EQ(pool.submit([&] { ++ran; }), WorkerPool::Submit::closed);
  // Busy: wait_idle gives up at its deadline.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(pool.wait_idle(t0 + 50ms));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 50ms);
  gate.open();
  EXPECT_TRUE(pool.wait_idle(std::chrono::steady_clock::now() + 10s));
  EXPECT_EQ(ran.load(), 6);  // tasks queued before close still ran
  pool.join();
  pool.join();  // idempotent
  EXPECT_EQ(pool.busy(), 0u);
  EXPECT_EQ(pool.queue_depth(), 0u);
}

TEST(WorkerPool, DestructorRunsWhatWasQueued) {
  std::atomic<int> ran{0};
  {
    WorkerPool pool(1, 100);
    for (int i = 0; i < 50; ++i)
      ASSERT_EQ(pool.submit([&] { std::this_thread::sleep_for(100us); ++ran; }), WorkerPool::Submit::accepted);
  }
  EXPECT_EQ(ran.load(), 50);
}

TEST(WorkerPool, ThrowingTasksDoNotStopTheWorkers) {
  WorkerPool pool(2, 100);
  std::atomic<int> ran{0};
  for (int i = 0; i < 40; ++i) {
    ASSERT_EQ(pool.submit([&, i] {
                ++ran;
                if (i % 2) throw std::runtime_error("task failure");
              }),
              WorkerPool::Submit::accepted);
  }
  ASSERT_TRUE(pool.wait_idle(std::chrono::steady_clock::now() + 10s));
  EXPECT_EQ(ran.load(), 40);
  EXPECT_EQ(pool.workers(), 2u);
}

TEST(WorkerPool, ManyTasksFromManyThreadsRunExactlyOnce) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 6; ++trial) {
    const std::size_t workers = 1 + rng() % 4, capacity = 1 + rng() % 64;
    constexpr int kThreads = 8, kTasksPerThread = 500;
    WorkerPool pool(workers, capacity);
    std::vector<std::atomic<int>> runs(kThreads * kTasksPerThread);
    std::vector<std::atomic<bool>> accepted(kThreads * kTasksPerThread);
    std::vector<std::thread> submitters;
    for (int t = 0; t < kThreads; ++t) {
      submitters.emplace_back([&, t] {
        for (int i = 0; i < kTasksPerThread; ++i) {
          const int id = t * kTasksPerThread + i;
          // A full queue refuses at once; half of the submitters retry, the others give up.
          for (;;) {
            const WorkerPool::Submit s = pool.submit([&runs, id] { ++runs[id]; });
            if (s == WorkerPool::Submit::accepted) {
              accepted[id] = true;
              break;
            }
            EXPECT_EQ(s, WorkerPool::Submit::queue_full);
            if (t % 2) break;
            std::this_thread::yield();
          }
          EXPECT_LE(pool.queue_depth(), capacity + workers);  // idle workers take theirs at once
        }
      });
    }
    for (auto& s : submitters) s.join();
    ASSERT_TRUE(pool.wait_idle(std::chrono::steady_clock::now() + 30s));
    pool.join();
    int accepted_count = 0;
    for (std::size_t id = 0; id < runs.size(); ++id) {
      ASSERT_EQ(runs[id].load(), accepted[id] ? 1 : 0) << "task " << id;
      accepted_count += accepted[id];
    }
    // The retrying submitters got every task in.
    EXPECT_GE(accepted_count, kThreads / 2 * kTasksPerThread);
  }
}

}  // namespace
}  // namespace lipmap::server
