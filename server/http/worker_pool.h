// The engine's fixed worker pool behind a bounded queue (docs/architecture.md): HTTP threads only parse,
// enqueue and answer; every engine call runs here. A full queue refuses new work at once (the HTTP layer
// answers 503 + Retry-After) instead of letting latency grow without bound.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace lipmap::server {

class WorkerPool {
public:
  using Task = std::function<void()>;
  using Clock = std::chrono::steady_clock;

  // workers >= 1 threads; at most queue_capacity tasks wait (tasks being run do not count).
  WorkerPool(std::size_t workers, std::size_t queue_capacity);
  ~WorkerPool();  // close() and join(): waits for queued tasks to run
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  enum class Submit { accepted, queue_full, closed };
  // Never blocks. A task must not throw (an escaping exception is swallowed, never fatal). When accepted
  // and `ticket` is given, it receives a number that remove() takes.
  Submit submit(Task task, std::uint64_t* ticket = nullptr);
  // Takes a task that is still waiting out of the queue (its place is free at once); false when a worker
  // has already taken it.
  bool remove(std::uint64_t ticket);

  // Stop accepting; tasks already queued still run.
  void close();
  // Waits until nothing is queued or running, or until the deadline; true when idle.
  bool wait_idle(Clock::time_point deadline);
  // close() and wait for the threads to end (after the queue is empty).
  void join();

  std::size_t workers() const { return threads_.size(); }
  std::size_t capacity() const { return capacity_; }
  std::size_t queue_depth() const;
  // True when submit() would answer queue_full now: lets the HTTP layer refuse before reading a body.
  bool full() const;
  std::size_t busy() const;
  // Exponential moving average of task run times, seconds (0 until a task finished).
  double mean_task_seconds() const;
  // Seconds a client should wait before retrying when the queue is full: the time the queue needs to
  // drain at the current pace, between 1 and 60.
  int retry_after_seconds() const;

private:
  void run();
  bool full_locked() const;  // with mutex_ held

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable work_cv_, idle_cv_;
  std::deque<std::pair<std::uint64_t, Task>> queue_;
  std::uint64_t next_ticket_ = 1;
  std::size_t running_ = 0;
  bool closed_ = false;
  double mean_seconds_ = 0;
  bool trim_due_ = false;  // a long task ended since the last malloc_trim (worker_pool.cpp)
  std::vector<std::thread> threads_;
};

}  // namespace lipmap::server
