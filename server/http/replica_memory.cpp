#include "server/http/replica_memory.h"

// ---- Handoffs ---------------------------------------------------------------------------------------------

namespace lipmap::server {

void Handoffs::put(const std::string& id, Parsed parsed) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (by_id_.emplace(id, std::move(parsed)).second) order_.push_back(id);
  while (by_id_.size() > max_entries_ && !order_.empty()) {
    by_id_.erase(order_.front());
    order_.pop_front();
  }
  // Ids taken long ago: the list never grows past twice the entries.
  if (order_.size() > 2 * max_entries_) {
    std::list<std::string> live;
    for (const std::string& k : order_)
      if (by_id_.count(k)) live.push_back(k);
    order_.swap(live);
  }
}

std::optional<Handoffs::Parsed> Handoffs::take(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = by_id_.find(id);
  if (it == by_id_.end()) return std::nullopt;
  Parsed p = std::move(it->second);
  by_id_.erase(it);
  return p;
}

std::size_t Handoffs::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return by_id_.size();
}

}  // namespace lipmap::server

// ---- LocalResults -----------------------------------------------------------------------------------------

namespace lipmap::server {

LocalResults::LocalResults(std::size_t max_entries, std::size_t max_bytes, std::chrono::milliseconds ttl)
    : max_entries_(max_entries), max_bytes_(max_bytes), ttl_(ttl) {}

void LocalResults::put(const std::string& id, ComputedResult result) {
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto it = by_id_.find(id); it != by_id_.end()) {
    bytes_ -= it->second->bytes;
    order_.erase(it->second);
    by_id_.erase(it);
  }
  const std::size_t bytes = result.json ? result.json->size() : 0;
  if (bytes > max_bytes_) return;  // would leave room for nothing else
  order_.push_front(Entry{id, std::move(result), bytes, now + ttl_});
  by_id_[id] = order_.begin();
  bytes_ += bytes;
  trim_locked(now);
}

std::optional<ComputedResult> LocalResults::get(const std::string& id) {
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  trim_locked(now);
  auto it = by_id_.find(id);
  if (it == by_id_.end()) return std::nullopt;
  order_.splice(order_.begin(), order_, it->second);  // most recently used
  return it->second->result;
}

void LocalResults::erase(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto it = by_id_.find(id); it != by_id_.end()) {
    bytes_ -= it->second->bytes;
    order_.erase(it->second);
    by_id_.erase(it);
  }
}

std::size_t LocalResults::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return order_.size();
}

void LocalResults::trim_locked(Clock::time_point now) {
  // Expired entries anywhere, then the least recently used while over a bound.
  for (auto it = order_.begin(); it != order_.end();) {
    if (it->expires > now) {
      ++it;
      continue;
    }
    bytes_ -= it->bytes;
    by_id_.erase(it->id);
    it = order_.erase(it);
  }
  while (!order_.empty() && (order_.size() > max_entries_ || bytes_ > max_bytes_)) {
    bytes_ -= order_.back().bytes;
    by_id_.erase(order_.back().id);
    order_.pop_back();
  }
}

}  // namespace lipmap::server
