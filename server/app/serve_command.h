// `lipmap serve`: the HTTP service (server/http/http_server.h) as a subcommand. cli.cpp registers it with
// add_serve_subcommand() and runs it with serve_command() when it was parsed.
#pragma once

#include <iosfwd>
#include <string>

#include "server/http/http_server.h"

namespace CLI {
class App;
}

namespace lipmap::cli {

struct ServeOptions {
  server::ServerConfig config;
  std::string log_level = "info";
};

// Adds the `serve` subcommand with one flag and one environment variable per setting (--port /
// LIPMAP_PORT, ...); the values land in `options`.
CLI::App* add_serve_subcommand(CLI::App& app, ServeOptions& options);

// Runs the service until SIGTERM or SIGINT, then drains (server/http/http_server.h) and returns 0. A second
// signal cancels the remaining work at once. Usage errors return 2, a port that cannot be bound 1, each
// with one line on `err` ("lipmap: error: <code>: <message>"). Logs are JSON lines on standard error.
int serve_command(const ServeOptions& options, std::ostream& out, std::ostream& err);

}  // namespace lipmap::cli
