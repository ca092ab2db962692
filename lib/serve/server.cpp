#include "serve/server.hpp"

#include <httplib.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <sstream>

#include "serve/api.hpp"
#include "serve/computations.hpp"
#include "serve/query.hpp"
#include "serve/rate_limit.hpp"
#include "serve/web_assets.hpp"
#include "util/errors.hpp"
#include "util/free_memory.hpp"

namespace ssrfleet::serve {

using nlohmann::json;

namespace {

constexpr std::size_t kMaxBodyBytes = 4096;
constexpr int kListenBacklog = 256;  // connections waiting for accept()

double now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

void send_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump(-1, ' ', false, json::error_handler_t::replace), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message, const json& parameter) {
  send_json(res, status, {{"error", message}, {"parameter", parameter}});
}

}  // namespace

Server::Server(std::vector<StateConfig> states, ServeOptions options)
    : options_(std::move(options)),
      http_(std::make_unique<httplib::Server>()),
      computations_(std::make_unique<Computations>(options_.queue_limit, options_.cache_limit)),
      limiter_(std::make_unique<RateLimiter>(options_.rate_per_s, options_.burst)) {
  for (auto& s : states) states_.push_back(std::make_unique<ServedState>(std::move(s)));
  const int threads = options_.http_threads;
  http_->new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<std::size_t>(threads)); };
  // One request per connection: a kept-alive idle connection would hold one of the few threads.
  http_->set_keep_alive_max_count(1);
  http_->set_read_timeout(5, 0);
  http_->set_write_timeout(5, 0);
  http_->set_payload_max_length(kMaxBodyBytes);
  // The listening socket: SO_REUSEADDR only (a restart may bind at once), not httplib's default
  // SO_REUSEPORT, with which a second server on the same port would bind too and silently take
  // half the connections. httplib listens with a backlog of 5 connections: a second's worth of pages
  // polling at once overflows it, and each connection refused costs its client a 1 s SYN retry. So
  // the socket is remembered here and given a real backlog after bind() (Linux takes a second
  // listen() as a new backlog).
  http_->set_socket_options([this](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    listen_fd_ = sock;
  });
  http_->set_default_headers({{"X-Content-Type-Options", "nosniff"}, {"Referrer-Policy", "no-referrer"}});
  // Every request comes through here, whatever its method and path: the routing is ours.
  http_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    handle(req, res);
    return httplib::Server::HandlerResponse::Handled;
  });
  // What httplib refuses before routing (a request line too long, a body too large, a malformed
  // request) still gets a JSON body.
  http_->set_error_handler([](const httplib::Request&, httplib::Response& res) {
    if (!res.body.empty()) return;
    const std::string why = res.status == 414   ? "the request line is longer than 8192 bytes"
                            : res.status == 413 ? "a request body is not accepted past 4096 bytes"
                                                : "the request was refused";
    send_error(res, res.status, why, "request");
  });
}

Server::~Server() {
  stop();
  if (poller_.joinable()) poller_.join();
}

int Server::bind() {
  for (auto& s : states_) s->refresh();
  if (options_.port == 0) {
    port_ = http_->bind_to_any_port(options_.bind);
  } else {
    port_ = http_->bind_to_port(options_.bind, options_.port) ? options_.port : -1;
  }
  if (port_ <= 0) {
    throw IoError("cannot listen on " + options_.bind + ":" + std::to_string(options_.port) +
                  " (in use, or not an address of this machine)");
  }
  if (listen_fd_ >= 0) ::listen(listen_fd_, kListenBacklog);
  poller_ = std::thread([this] { poll_loop(); });
  return port_;
}

void Server::run() { http_->listen_after_bind(); }

void Server::stop() {
  stopping_.store(true);
  http_->stop();
}

void Server::poll_loop() {
  for (long polls = 1; !stopping_.load(); ++polls) {
    for (auto& s : states_) s->refresh();
    // The request threads' freed buffers (answers of up to a few hundred kB) go back every 10 s.
    if (polls % static_cast<long>(std::max(1.0, 10.0 / options_.poll_s)) == 0) util::return_free_memory();
    for (int i = 0; i < 10 && !stopping_.load(); ++i) {
      std::this_thread::sleep_for(std::chrono::duration<double>(options_.poll_s / 10.0));
    }
  }
}

void Server::handle(const httplib::Request& req, httplib::Response& res) {
  if (req.method != "GET" && req.method != "HEAD") {
    res.set_header("Allow", "GET, HEAD");
    // Its body (if any) was not read: close rather than parse it as the next request.
    res.set_header("Connection", "close");
    send_error(res, 405, "method " + req.method.substr(0, 16) + " is not allowed: only GET and HEAD",
               "method");
    return;
  }
  if (!req.body.empty() || req.has_header("Content-Length") || req.has_header("Transfer-Encoding")) {
    if (req.get_header_value("Content-Length") != "0") {
      res.set_header("Connection", "close");
      send_error(res, 413, "a GET request takes no body", "request");
      return;
    }
  }
  if (const double wait_s = limiter_->take(req.remote_addr, now_s()); wait_s > 0.0) {
    res.set_header("Retry-After", std::to_string(static_cast<int>(std::ceil(wait_s))));
    std::ostringstream why;
    why << "too many requests from " << req.remote_addr << ": at most " << options_.rate_per_s
        << " a second (bursts of " << options_.burst << ")";
    send_error(res, 429, why.str(), nullptr);
    return;
  }
  // The raw target: the path as sent (no decoding, so "%2e%2e" stays what it is) and the query.
  const std::string& target = req.target;
  const std::size_t mark = target.find('?');
  const std::string path = target.substr(0, mark);
  const std::string query = mark == std::string::npos ? "" : target.substr(mark + 1);
  if (const WebAsset* asset = find_web_asset(path)) {
    if (!query.empty()) {
      send_error(res, 400, "the page's files take no query", "query");
      return;
    }
    res.set_header("Cache-Control", "no-cache");
    res.set_header(
        "Content-Security-Policy",
        "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; object-src 'none'");
    res.set_content(asset->body.data(), asset->body.size(), std::string(asset->content_type).c_str());
    return;
  }
  if (path.rfind("/api/", 0) == 0) {
    route_api(path, query, res);
    return;
  }
  send_error(res, 404, "no such path: " + path.substr(0, 200), nullptr);
}

ServedState& Server::pick_state(const Query& q) {
  const auto name = q.label("state");
  if (!name) {
    if (states_.size() == 1) return *states_.front();
    throw QueryError("state", "this server follows " + std::to_string(states_.size()) +
                                  " states: name one (GET /api/states lists them)");
  }
  for (auto& s : states_) {
    if (s->config().name == *name) return *s;
  }
  throw QueryError("state", "no state '" + *name + "' (GET /api/states lists them)");
}

void Server::route_api(const std::string& path, const std::string& query, httplib::Response& res) {
  try {
    const Query q = Query::parse(query);
    if (path == "/api/states") {
      q.only({});
      send_json(res, 200, api_states(states_));
      return;
    }
    ApiResponse out;
    bool known = true;
    if (path == "/api/summary" || path == "/api/history" || path == "/api/rejects" || path == "/api/ssr" ||
        path == "/api/damage") {
      ServedState& state = pick_state(q);
      std::size_t index = 0;
      while (states_[index].get() != &state) ++index;
      if (path == "/api/summary") out = api_summary(state, q, now_s(), options_.idle_after_s);
      if (path == "/api/history") {
        const auto snapshot = state.view().snapshot;
        if (snapshot) {
          if (const auto body = state.cached_answer(query, snapshot->report.seq)) {
            res.status = 200;
            res.set_header("Cache-Control", "no-store");
            res.set_content(body->data(), body->size(), "application/json");
            return;
          }
        }
        out = api_history(state, q);
        if (out.status == 200) {
          auto body = std::make_shared<const std::string>(
              out.body.dump(-1, ' ', false, json::error_handler_t::replace));
          state.store_answer(query, out.body["checkpoint"]["seq"].get<std::uint64_t>(), body);
          res.status = 200;
          res.set_header("Cache-Control", "no-store");
          res.set_content(body->data(), body->size(), "application/json");
          return;
        }
      }
      if (path == "/api/rejects") out = api_rejects(state, q);
      if (path == "/api/ssr") out = api_ssr(state, index, q, *computations_);
      if (path == "/api/damage") out = api_damage(state, index, q, *computations_);
    } else {
      known = false;
    }
    if (!known) {
      send_error(res, 404, "no such path: " + path.substr(0, 200) + " (docs/serve.md lists the API)",
                 nullptr);
      return;
    }
    if (out.status == 202 || out.status == 503) res.set_header("Retry-After", "1");
    send_json(res, out.status, out.body);
  } catch (const QueryError& e) {
    send_error(res, 400, e.what(), e.parameter());
  } catch (const std::exception& e) {
    send_error(res, 500, e.what(), nullptr);
  }
}

}  // namespace ssrfleet::serve
