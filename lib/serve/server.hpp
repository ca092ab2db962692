// `ssrfleet serve` (docs/serve.md): one page and a JSON API over one or more stream states,
// read-only. The HTTP library is cpp-httplib (Debian's libcpp-httplib-dev); this file holds the
// routes and the rules every request meets:
//   - GET and HEAD only (405 otherwise, with Allow); a request body is refused (413 past 4 KiB);
//     the request line and each header at most 8 KiB (httplib's limits; 414 / 400 beyond);
//   - a token bucket per client address: `rate_per_s` requests a second, bursts of `burst` (429
//     with Retry-After past it);
//   - paths are matched exactly against the routes and the embedded assets: anything else is a
//     JSON 404, and nothing is ever read from disk for a path;
//   - a bad query parameter is a JSON 400 naming it ({"error": ..., "parameter": ...}).
// A poll thread refreshes every state every `poll_s`; the computations run on one worker at nice 19.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "serve/served_state.hpp"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace ssrfleet::serve {

class Computations;
class RateLimiter;

struct ServeOptions {
  std::string bind = "127.0.0.1";
  int port = 8080;           // 0: any free port (bound_port() says which)
  double rate_per_s = 20.0;  // per client address; <= 0 turns the limit off
  double burst = 40.0;
  int http_threads = 8;
  double poll_s = 0.25;          // how often each state is looked at
  double idle_after_s = 60.0;    // a running stream with no checkpoint for this long is "idle"
  std::size_t queue_limit = 8;   // distinct computations waiting
  std::size_t cache_limit = 32;  // computation results kept
};

class Server {
 public:
  Server(std::vector<StateConfig> states, ServeOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds the socket (IoError if it cannot) and starts the poll; returns the port.
  int bind();
  // Serves until stop() (from another thread or a signal handler's thread).
  void run();
  void stop();
  int bound_port() const { return port_; }

 private:
  void handle(const httplib::Request& req, httplib::Response& res);
  void route_api(const std::string& path, const std::string& query, httplib::Response& res);
  ServedState& pick_state(const class Query& q);
  void poll_loop();

  std::vector<std::unique_ptr<ServedState>> states_;
  ServeOptions options_;
  std::unique_ptr<httplib::Server> http_;
  std::unique_ptr<Computations> computations_;
  std::unique_ptr<RateLimiter> limiter_;
  int port_ = 0;
  int listen_fd_ = -1;  // the listening socket, as httplib made it
  std::atomic<bool> stopping_{false};
  std::thread poller_;
};

}  // namespace ssrfleet::serve
