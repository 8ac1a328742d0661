// Cooperative cancellation: long loops call check() now and then; a cancelled or expired token throws.
#pragma once

#include <atomic>
#include <chrono>

#include "engine/error.h"

namespace lipmap {

class CancelToken {
public:
  using Clock = std::chrono::steady_clock;

  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  void set_deadline(Clock::time_point deadline) { deadline_ = deadline; has_deadline_ = true; }

  bool expired() const {
    return cancelled_.load(std::memory_order_relaxed) || (has_deadline_ && Clock::now() >= deadline_);
  }
  void check() const {
    if (cancelled_.load(std::memory_order_relaxed)) throw Cancelled("cancelled");
    if (has_deadline_ && Clock::now() >= deadline_) throw Cancelled("deadline exceeded");
  }

private:
  std::atomic<bool> cancelled_{false};
  bool has_deadline_ = false;
  Clock::time_point deadline_{};
};

// Null-safe helper for stages that take an optional token.
inline void check_cancel(const CancelToken* token) {
  if (token) token->check();
}

}  // namespace lipmap
