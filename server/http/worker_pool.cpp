#include "server/http/worker_pool.h"

#include <malloc.h>

#include <algorithm>
#include <cmath>

namespace lipmap::server {

namespace {
constexpr double kTrimAfterSeconds = 0.5;
constexpr std::chrono::seconds kTrimDelay{1};
}  // namespace

WorkerPool::WorkerPool(std::size_t workers, std::size_t queue_capacity) : capacity_(queue_capacity) {
  workers = std::max<std::size_t>(workers, 1);
  threads_.reserve(workers);
  for (std::size_t i = 0; i < workers; ++i) threads_.emplace_back([this] { run(); });
}

WorkerPool::~WorkerPool() { join(); }

WorkerPool::Submit WorkerPool::submit(Task task, std::uint64_t* ticket) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return Submit::closed;
    if (full_locked()) return Submit::queue_full;
    const std::uint64_t t = next_ticket_++;
    queue_.emplace_back(t, std::move(task));
    if (ticket) *ticket = t;
  }
  work_cv_.notify_one();
  return Submit::accepted;
}

bool WorkerPool::full_locked() const {
  // Idle workers take queued tasks at once: the queue may hold `capacity_` tasks beyond those, so that
  // "waiting for a worker" never exceeds the capacity, even before an idle worker has woken up.
  const std::size_t idle = threads_.size() > running_ ? threads_.size() - running_ : 0;
  return queue_.size() + 1 > capacity_ + idle;
}

bool WorkerPool::full() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !closed_ && full_locked();
}

// malloc keeps what a job freed for the next one (the lipmap binary's glibc.malloc.trim_threshold,
// server/app/main.cpp). After a long task (the large jobs) an idle worker gives it back with malloc_trim, once the
// pool has stayed idle for kTrimDelay: by then an answer's memory freed on the HTTP thread after sending is free
// too, and a trim never holds up work that arrives at once. Not after short tasks only: a trim walks every free
// block, and at hundreds of small jobs a second that adds up.
void WorkerPool::run() {
  for (;;) {
    Task task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      const auto ready = [this] { return closed_ || !queue_.empty(); };
      while (!ready()) {
        if (!(trim_due_ && running_ == 0)) {
          work_cv_.wait(lock);
          continue;
        }
        if (work_cv_.wait_for(lock, kTrimDelay, ready)) break;
        if (trim_due_ && running_ == 0) {  // still idle: one of the idle workers trims
          trim_due_ = false;
          lock.unlock();
          malloc_trim(0);
          lock.lock();
        }
      }
      if (queue_.empty()) return;  // closed and drained
      task = std::move(queue_.front().second);
      queue_.pop_front();
      ++running_;
    }
    const auto start = Clock::now();
    try {
      task();
    } catch (...) {
      // Tasks catch their own errors; this only keeps a worker alive if one does not.
    }
    task = nullptr;  // what the task holds (a parsed request) is freed before the pool counts it done
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      --running_;
      mean_seconds_ = mean_seconds_ == 0 ? seconds : 0.8 * mean_seconds_ + 0.2 * seconds;
      if (seconds >= kTrimAfterSeconds) trim_due_ = true;
      if (running_ == 0 && queue_.empty()) idle_cv_.notify_all();
    }
  }
}

bool WorkerPool::remove(std::uint64_t ticket) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = queue_.begin(); it != queue_.end(); ++it) {
    if (it->first == ticket) {
      queue_.erase(it);
      if (running_ == 0 && queue_.empty()) idle_cv_.notify_all();
      return true;
    }
  }
  return false;
}

void WorkerPool::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  work_cv_.notify_all();
}

bool WorkerPool::wait_idle(Clock::time_point deadline) {
  std::unique_lock<std::mutex> lock(mutex_);
  return idle_cv_.wait_until(lock, deadline, [this] { return running_ == 0 && queue_.empty(); });
}

void WorkerPool::join() {
  close();
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
}

std::size_t WorkerPool::queue_depth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

std::size_t WorkerPool::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_;
}

double WorkerPool::mean_task_seconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return mean_seconds_;
}

int WorkerPool::retry_after_seconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const double pending = static_cast<double>(queue_.size() + running_);
  const double seconds = pending * mean_seconds_ / static_cast<double>(threads_.size());
  return static_cast<int>(std::clamp(std::ceil(seconds), 1.0, 60.0));
}

}  // namespace lipmap::server
