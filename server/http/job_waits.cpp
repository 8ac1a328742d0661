#include "server/http/job_waits.h"

namespace lipmap::server {

JobWaits::Place::~Place() {
  if (!waits_) return;
  std::lock_guard<std::mutex> lock(waits_->mutex_);
  --waits_->waiting_;
}

JobWaits::Place JobWaits::enter() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_ || waiting_ >= max_waiters_) return Place();
  ++waiting_;
  return Place(this);
}

std::uint64_t JobWaits::generation() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return generation_;
}

void JobWaits::sleep(std::uint64_t seen, Clock::time_point until) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_until(lock, until, [&] { return closed_ || generation_ != seen; });
}

void JobWaits::notify() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++generation_;
  }
  changed_.notify_all();
}

void JobWaits::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

bool JobWaits::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

std::size_t JobWaits::waiting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return waiting_;
}

}  // namespace lipmap::server
