#include "server/http/connection.h"

#include <algorithm>
#include <array>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>
#include <utility>

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace lipmap::server {

namespace {

using Clock = std::chrono::steady_clock;

// One connection's socket, buffered across its requests (a pipelined request already read into the buffer
// is the next one served), with a deadline on reads.
class DeadlineStream final : public httplib::Stream {
public:
  DeadlineStream(socket_t sock, const ConnectionLimits& limits, std::chrono::milliseconds read_timeout,
                 std::chrono::milliseconds write_timeout)
      : sock_(sock), limits_(limits), read_timeout_(read_timeout), write_timeout_(write_timeout) {}

  // Waits (at most `idle`, or until `stopping` says so) for the first byte of the next request.
  template <typename Stopping>
  bool wait_for_request(std::chrono::milliseconds idle, Stopping stopping) {
    if (begin_ < end_) return true;
    const auto until = Clock::now() + idle;
    while (!stopping()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now());
      if (left.count() <= 0) return false;
      const int r = poll_for(POLLIN, std::min<long long>(left.count(), 100));
      if (r < 0) return false;
      if (r > 0) return true;
    }
    return false;
  }

  void begin_request() {
    start_ = Clock::now();
    deadline_ = start_ + limits_.header_timeout;
    timed_out_ = false;
    write_failed_ = false;
  }
  void header_received() { deadline_ = start_ + limits_.request_timeout; }
  bool timed_out() const { return timed_out_; }
  bool write_failed() const { return write_failed_; }

  // Reads and drops `bytes` when they are all here already (buffered or in the socket); never waits.
  bool discard_ready(std::size_t bytes) {
    std::array<char, 4096> sink{};
    while (bytes > 0 && is_readable()) {
      const ssize_t n = read(sink.data(), std::min(bytes, sink.size()));
      if (n <= 0) return false;
      bytes -= static_cast<std::size_t>(n);
    }
    return bytes == 0;
  }

  bool is_readable() const override { return begin_ < end_ || poll_for(POLLIN, 0) > 0; }
  bool is_writable() const override { return poll_for(POLLOUT, 0) > 0; }

  ssize_t read(char* ptr, size_t size) override {
    if (begin_ == end_) {
      const auto now = Clock::now();
      if (now >= deadline_) {
        timed_out_ = true;
        return -1;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - now) + std::chrono::milliseconds(1);
      const int r = poll_for(POLLIN, std::min(left, read_timeout_).count());
      if (r == 0 && Clock::now() >= deadline_) timed_out_ = true;
      if (r <= 0) return -1;
      ssize_t n;
      do {
        n = ::recv(sock_, buffer_.get(), kBufferSize, 0);
      } while (n < 0 && errno == EINTR);
      if (n <= 0) return n;
      begin_ = 0;
      end_ = static_cast<std::size_t>(n);
    }
    const std::size_t n = std::min(size, end_ - begin_);
    std::memcpy(ptr, buffer_.get() + begin_, n);
    begin_ += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (write_failed_) return -1;
    ssize_t n = -1;
    if (poll_for(POLLOUT, write_timeout_.count()) > 0) {
      do {
        n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
      } while (n < 0 && errno == EINTR);
    }
    if (n < 0) write_failed_ = true;
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(false, ip, port); }
  socket_t socket() const override { return sock_; }

private:
  int poll_for(short events, long long ms) const {
    pollfd p{sock_, events, 0};
    int r;
    do {
      r = ::poll(&p, 1, static_cast<int>(ms));
    } while (r < 0 && errno == EINTR);
    if (r > 0 && (p.revents & (POLLERR | POLLNVAL)) && !(p.revents & events)) return -1;
    return r;
  }

  void address(bool remote, std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    const int r = remote ? ::getpeername(sock_, reinterpret_cast<sockaddr*>(&addr), &len)
                         : ::getsockname(sock_, reinterpret_cast<sockaddr*>(&addr), &len);
    if (r != 0) return;
    std::array<char, NI_MAXHOST> host{};
    std::array<char, NI_MAXSERV> serv{};
    if (::getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host.data(), host.size(), serv.data(), serv.size(),
                      NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
      ip = host.data();
      port = std::atoi(serv.data());
    }
  }

  socket_t sock_;
  const ConnectionLimits& limits_;
  std::chrono::milliseconds read_timeout_, write_timeout_;
  // 256 kB: a 12.7 MB body took 775 poll + recv pairs at 16 kB (cpp-httplib then copies it out 4 kB at a
  // time, from this buffer). Not zeroed: only what recv wrote is read; untouched pages cost an idle
  // connection nothing.
  static constexpr std::size_t kBufferSize = 256 * 1024;
  std::unique_ptr<char[]> buffer_{new char[kBufferSize]};
  std::size_t begin_ = 0, end_ = 0;
  Clock::time_point start_{}, deadline_{};
  bool timed_out_ = false, write_failed_ = false;
};

thread_local DeadlineStream* tl_stream = nullptr;
// Set by ConnectionQueue on the listener thread while it runs a connection beyond the cap.
thread_local bool tl_refuse = false;

// Closes every connection after its peer has read the last answer (a 503 refusal, a 413 sent before the body):
// closing a socket with unread input makes the kernel send a reset, which can destroy the answer before the
// client reads it. add() shuts the write side and keeps the socket, reading and dropping what still comes,
// until the peer closes or 2 s pass; at most 64 at once, beyond which they close at once.
class Closer {
public:
  Closer() : thread_([this] { run(); }) {}
  ~Closer() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
    for (auto& [s, t] : sockets_) ::close(s);
  }
  void add(socket_t s) {
    ::shutdown(s, SHUT_WR);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (sockets_.size() < 64) {
        sockets_.emplace_back(s, Clock::now() + std::chrono::seconds(2));
        s = -1;
      }
    }
    if (s >= 0) ::close(s);
    cv_.notify_all();
  }

private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      if (sockets_.empty()) {
        cv_.wait(lock);
        continue;
      }
      std::vector<std::pair<socket_t, Clock::time_point>> open(sockets_.begin(), sockets_.end());
      sockets_.clear();
      lock.unlock();
      std::vector<pollfd> fds;
      for (auto& [s, t] : open) fds.push_back({s, POLLIN, 0});
      ::poll(fds.data(), fds.size(), 50);
      std::vector<std::pair<socket_t, Clock::time_point>> keep;
      const auto now = Clock::now();
      for (std::size_t i = 0; i < open.size(); ++i) {
        bool done = now >= open[i].second;
        if (fds[i].revents) {
          std::array<char, 4096> sink{};
          const ssize_t n = ::recv(open[i].first, sink.data(), sink.size(), MSG_DONTWAIT);
          done |= n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK);
        }
        if (done)
          ::close(open[i].first);
        else
          keep.push_back(open[i]);
      }
      lock.lock();
      sockets_.insert(sockets_.end(), keep.begin(), keep.end());
    }
  }

  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::deque<std::pair<socket_t, Clock::time_point>> sockets_;
  std::thread thread_;
};

// At most max_connections connections are served; one more is run right here on the listener thread, marked
// to be refused.
class ConnectionQueue final : public httplib::TaskQueue {
public:
  explicit ConnectionQueue(std::size_t capacity) : capacity_(capacity), pool_(capacity) {}
  void enqueue(std::function<void()> fn) override {
    if (open_.load() >= capacity_) {
      tl_refuse = true;
      fn();
      tl_refuse = false;
      return;
    }
    ++open_;  // only the listener thread enqueues: the check and the increment cannot race
    pool_.enqueue([this, fn = std::move(fn)] {
      fn();
      --open_;
    });
  }
  void shutdown() override { pool_.shutdown(); }

private:
  const std::size_t capacity_;
  std::atomic<std::size_t> open_{0};
  httplib::ThreadPool pool_;
};

class ConnectionServer final : public httplib::Server {
public:
  ConnectionServer(ConnectionLimits limits, std::function<std::string()> refusal)
      : limits_(limits), refusal_(std::move(refusal)) {
    const std::size_t capacity = limits.max_connections;
    new_task_queue = [capacity] { return new ConnectionQueue(capacity); };
  }

private:
  bool process_and_close_socket(socket_t sock) override {
    if (tl_refuse) {
      refuse(sock);
      return false;
    }
    using std::chrono::milliseconds;
    auto ms = [](time_t sec, time_t usec) { return milliseconds(sec * 1000 + usec / 1000); };
    DeadlineStream strm(sock, limits_, ms(read_timeout_sec_, read_timeout_usec_),
                        ms(write_timeout_sec_, write_timeout_usec_));
    tl_stream = &strm;
    bool ret = false;
    std::size_t count = keep_alive_max_count_;
    auto stopping = [this] { return svr_sock_ == INVALID_SOCKET; };
    while (count > 0 && !stopping() && strm.wait_for_request(milliseconds(keep_alive_timeout_sec_ * 1000), stopping)) {
      strm.begin_request();
      bool connection_closed = false;
      ret = process_request(strm, count == 1, connection_closed, nullptr);
      // After a 408 the rest of the late request would be read as a next one: the connection ends.
      if (!ret || connection_closed || strm.timed_out()) break;
      --count;
    }
    tl_stream = nullptr;
    closer_.add(sock);  // a lingering close: see Closer
    return ret;
  }

  void refuse(socket_t sock) {
    const std::string answer = refusal_();
    // Whatever of the request is already here is read first, so that closing does not reset the connection.
    std::array<char, 4096> sink{};
    while (::recv(sock, sink.data(), sink.size(), MSG_DONTWAIT) > 0) {
    }
    // A fresh socket's send buffer takes the whole small answer; never block the listener on it.
    (void)::send(sock, answer.data(), answer.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    closer_.add(sock);
  }

  const ConnectionLimits limits_;
  const std::function<std::string()> refusal_;
  Closer closer_;
};

}  // namespace

std::unique_ptr<httplib::Server> make_connection_server(ConnectionLimits limits, std::function<std::string()> refusal) {
  return std::make_unique<ConnectionServer>(limits, std::move(refusal));
}

void connection_header_received() {
  if (tl_stream) tl_stream->header_received();
}
bool connection_discard_ready(std::size_t bytes) { return tl_stream && tl_stream->discard_ready(bytes); }
bool connection_timed_out() { return tl_stream && tl_stream->timed_out(); }
bool connection_write_failed() { return tl_stream && tl_stream->write_failed(); }

}  // namespace lipmap::server
