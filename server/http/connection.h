// Connections of the HTTP service: how long a client may take to send a request, how many connections are
// served at once, and what happens beyond that (docs/api.md "Connections"). cpp-httplib 0.11 bounds each
// read only, so a client sending one byte per read timeout held a connection thread forever; its keep-alive
// loop also made a new buffered stream per request, which dropped a pipelined second request.
//
// ConnectionServer keeps cpp-httplib's request parsing, routing and answer writing (Server::process_request)
// and replaces only the per-connection loop around it: one buffered DeadlineStream per connection, whose
// reads fail once the request's deadline passes (head: header_timeout from its first byte; the whole
// request with its body: request_timeout). ConnectionQueue caps the open connections; one beyond is answered
// 503 at once and closed, by the listener thread itself, so it never waits for a connection thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>

namespace httplib {
class Server;
}

namespace lipmap::server {

struct ConnectionLimits {
  std::chrono::milliseconds header_timeout{10000};   // request line and headers, from the first byte
  std::chrono::milliseconds request_timeout{60000};  // head and body, from the first byte
  std::size_t max_connections = 512;                 // served at once; one thread each
};

// A cpp-httplib server with this connection loop and connection cap. `refusal` gives the raw bytes of the
// answer to a connection beyond the cap (a whole HTTP/1.1 503 with Connection: close); it runs on the
// listener thread and must be quick.
std::unique_ptr<httplib::Server> make_connection_server(ConnectionLimits limits, std::function<std::string()> refusal);

// The connection the calling thread serves (for the middleware; all false outside a connection thread).
// header_received(): the head is in, the deadline becomes the whole request's. timed_out(): a read failed
// for the deadline (the answer is 408). write_failed(): the client went away before the answer was out.
void connection_header_received();
// Reads and drops the next `bytes` of the connection (a body that will not be read) if they have all arrived
// already; never waits. False: not all here (the connection must then close).
bool connection_discard_ready(std::size_t bytes);
bool connection_timed_out();
bool connection_write_failed();

}  // namespace lipmap::server
