// ssrfleet serve's API against a real stream state, over real sockets: what each path answers
// (with units), every error the guide lists (400 naming the parameter, 404, 405, 413, 414, 429),
// no way out of the embedded assets, the SSR at typed positions and the damage equal to what
// `predict` and `damage` compute from the same posterior, and nothing in the state opened but the
// files serve reads.
#include <sys/inotify.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <thread>

#include <catch2/catch.hpp>

#include "io/csv_reader.hpp"
#include "serve/server.hpp"
#include "serve_client.hpp"
#include "site/road_source.hpp"
#include "test_support.hpp"

using namespace ssrfleet;
using test::http_get;
using test::http_raw;

namespace {

// One stream state for every test here: 30 trucks of AS1 and two bad records, streamed once.
struct StreamedState {
  test::TempDir dir;
  std::string state;
  StreamedState() {
    state = dir.file("site_state");
    REQUIRE(test::run_ssrfleet("simulate --road AS1 --trucks 30 --seed 7 --out '" + dir.file("log.csv") + "'",
                               dir)
                .status == 0);
    std::string log = test::read_text(dir.file("log.csv"));
    // A speed out of range and a repeated truck id: two records for the quarantine.
    std::istringstream lines(log);
    std::string line, header, first;
    while (std::getline(lines, line)) {
      if (line.empty() || line[0] == '#') continue;
      if (header.empty()) {
        header = line;
      } else if (first.empty()) {
        first = line;
      }
    }
    // The columns are truck_id,speed_mps,...: a new id at 95 m/s, then the first record again.
    const std::size_t c1 = first.find(','), c2 = first.find(',', c1 + 1);
    const std::string fast = "BAD1,95" + first.substr(c2);
    log += fast + "\n" + first + "\n";
    test::write_text(dir.file("log.csv"), log);
    const auto run = test::run_ssrfleet(
        "stream --state '" + state + "' --input '" + dir.file("log.csv") + "' --particles 128 --quiet", dir);
    REQUIRE(run.status == 0);
  }
};

StreamedState& streamed() {
  static StreamedState s;
  return s;
}

// A server on a free port over the state, running on its own thread for the test's life.
struct RunningServer {
  site::Site site{site::load_road("AS1", nullptr), site::SiteOptions{}};
  std::unique_ptr<serve::Server> server;
  std::thread thread;
  int port = 0;
  explicit RunningServer(const std::string& state, serve::ServeOptions options = {}) {
    options.port = 0;
    server = std::make_unique<serve::Server>(
        std::vector<serve::StateConfig>{{"site_state", state, {{"", &site}}}}, options);
    port = server->bind();
    thread = std::thread([this] { server->run(); });
  }
  ~RunningServer() {
    server->stop();
    thread.join();
  }
};

// Asks until the worker has the result (202 meanwhile), for at most a minute.
test::HttpReply computed(int port, const std::string& target) {
  test::HttpReply r;
  for (int i = 0; i < 600; ++i) {
    r = http_get(port, target);
    if (r.status != 202) return r;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return r;
}

std::vector<std::vector<double>> csv_numbers(const std::string& text) {
  std::vector<std::vector<double>> rows;
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<double> row;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

TEST_CASE("serve API: summary, SSR, history and rejects of one checkpoint, with units", "[serve]") {
  RunningServer s(streamed().state);
  const auto states = http_get(s.port, "/api/states");
  REQUIRE(states.status == 200);
  CHECK(states.json()["states"][0]["name"] == "site_state");

  const auto summary = http_get(s.port, "/api/summary");
  REQUIRE(summary.status == 200);
  CHECK(summary.header("content-type") == "application/json");
  const auto j = summary.json();
  CHECK(j["status"] == "stopped");  // the stream has exited: nobody holds the lock
  CHECK(j["lock_pid"].is_null());
  CHECK(j["checkpoint"]["trucks"] == 30);
  CHECK(j["checkpoint"]["seq"] == 30);
  CHECK(j["rejected"] == 2);
  REQUIRE(j["hyperparameters"].size() == 7);
  CHECK(j["hyperparameters"][0]["name"] == "K");
  CHECK(j["hyperparameters"][0]["unit"] == "N/m");
  CHECK(j["hyperparameters"][4]["unit"] == "m");
  CHECK(j["units"]["trucks_per_min"] == "trucks/min");

  const auto ssr = http_get(s.port, "/api/ssr");
  REQUIRE(ssr.status == 200);
  const auto sj = ssr.json();
  CHECK(sj["source"] == "history");
  CHECK(sj["checkpoint"]["seq"] == 30);
  REQUIRE(sj["ssr"]["position_m"].size() == 16);  // one point per sensor
  CHECK(sj["ssr"]["position_m"][0] == 76.0);
  CHECK(sj["ssr"]["position_m"][15] == 76.0 + 15 * 1.5);
  CHECK(sj["units"]["position_m"] == "m");
  for (int i = 0; i < 16; ++i) {
    CHECK(sj["ssr"]["lower95"][i].get<double>() < sj["ssr"]["mean_if"][i].get<double>());
    CHECK(sj["ssr"]["mean_if"][i].get<double>() < sj["ssr"]["upper95"][i].get<double>());
  }

  const auto history = http_get(s.port, "/api/history?param=sigma_if&points=10");
  REQUIRE(history.status == 200);
  const auto hj = history.json();
  REQUIRE(hj["series"].size() == 1);
  const auto& trucks = hj["series"][0]["trucks"];
  CHECK(trucks.size() <= 10);
  CHECK(trucks.size() >= 9);
  CHECK(trucks.front() == 1);
  CHECK(trucks.back() == 30);  // the checkpoint's own value is always drawn
  CHECK(hj["series"][0]["mean"].back().get<double>() ==
        Approx(j["hyperparameters"][6]["mean"].get<double>()));
  CHECK(http_get(s.port, "/api/history").json()["series"].size() == 7);
  const auto range = http_get(s.port, "/api/history?from=10&to=12").json();
  CHECK(range["series"][0]["trucks"] == nlohmann::json({10, 11, 12}));

  const auto rejects = http_get(s.port, "/api/rejects");
  REQUIRE(rejects.status == 200);
  const auto rj = rejects.json();
  CHECK(rj["rejected"] == 2);
  REQUIRE(rj["last"].size() == 2);
  CHECK(rj["last"][0]["field"] == "speed_mps");
  CHECK(rj["last"][0]["reason"].get<std::string>().find("95 m/s") != std::string::npos);
  CHECK(rj["last"][1]["field"] == "truck_id");
  CHECK(rj["last"][1]["line"].get<int>() > 30);

  const auto page = http_get(s.port, "/");
  REQUIRE(page.status == 200);
  CHECK(page.header("content-type") == "text/html; charset=utf-8");
  CHECK(page.body.find("ssr-chart") != std::string::npos);
  const auto chart = http_get(s.port, "/chart.min.js");
  REQUIRE(chart.status == 200);
  CHECK(chart.body.find("Chart.js v3") != std::string::npos);
  CHECK(chart.body.size() > 100000);
}

TEST_CASE("serve API: every error gets its status and a JSON body naming what to fix", "[serve]") {
  RunningServer s(streamed().state);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"/api/summary?bogus=1", "bogus"},
      {"/api/ssr?positions=abc", "positions"},
      {"/api/ssr?positions=80,79", "positions"},
      {"/api/ssr?positions=0:0.001:5000", "positions"},
      {"/api/ssr?class=Z9", "class"},
      {"/api/ssr?site=north", "site"},
      {"/api/damage?class=A", "class"},
      {"/api/summary?state=other", "state"},
      {"/api/summary?state=..%2F..%2Fetc", "state"},
      {"/api/history?points=1", "points"},
      {"/api/history?points=2001", "points"},
      {"/api/history?from=0", "from"},
      {"/api/history?from=31", "from"},
      {"/api/history?from=20&to=10", "to"},
      {"/api/history?param=K%27%3B%20DROP%20TABLE%20reports", "param"},
      {"/api/rejects?limit=51", "limit"},
      {"/api/rejects?limit=1&limit=2", "limit"},
      {"/api/states?x=1", "x"},
      {"/api/summary?state=%zz", "state"},
      {"/?x=1", "query"},
  };
  for (const auto& [target, parameter] : bad) {
    INFO(target);
    const auto r = http_get(s.port, target);
    CHECK(r.status == 400);
    CHECK(r.header("content-type") == "application/json");
    CHECK(r.json()["parameter"] == parameter);
    CHECK(!r.json()["error"].get<std::string>().empty());
  }
  // The database still answers after the injection attempt above.
  CHECK(http_get(s.port, "/api/history?param=K").status == 200);

  // Unknown paths, and every way out of the embedded files: 404, and never a file's content.
  for (const std::string target :
       {"/api/nope", "/api", "/api/summary/", "/index.html", "/web/app.js", "/../CMakeLists.txt",
        "/%2e%2e/%2e%2e/etc/passwd", "/app.js/../../../etc/passwd", "//etc/passwd", "/..%2f..%2fetc%2fpasswd",
        "/static/../../history.sqlite", "/history.sqlite", "/site_state/history.sqlite", "/%00",
        "/chart.min.js%00"}) {
    INFO(target);
    const auto r = http_get(s.port, target);
    CHECK(r.status == 404);
    CHECK(r.json()["error"].get<std::string>().rfind("no such path", 0) == 0);
    CHECK(r.body.find("root:") == std::string::npos);
    CHECK(r.body.find("SQLite format") == std::string::npos);
  }

  // Only GET and HEAD.
  for (const std::string method : {"POST", "PUT", "DELETE", "PATCH", "OPTIONS"}) {
    INFO(method);
    const auto r =
        http_raw(s.port, method + " /api/summary HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n");
    CHECK(r.status == 405);
    CHECK(r.header("allow") == "GET, HEAD");
    CHECK(r.json()["parameter"] == "method");
  }
  const auto get = http_get(s.port, "/api/summary");
  const auto head = http_get(s.port, "/api/summary", "HEAD");
  CHECK(head.status == 200);
  CHECK(head.body.empty());
  CHECK(head.header("content-type") == "application/json");
  CHECK(http_get(s.port, "/nope", "HEAD").status == 404);

  // A request body, and a request line past 8 KiB.
  const auto with_body =
      http_raw(s.port, "GET /api/summary HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello");
  CHECK(with_body.status == 413);
  const auto huge_body =
      http_raw(s.port, "POST /api/summary HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n" +
                           std::string(100000, 'x'));
  CHECK((huge_body.status == 405 || huge_body.status == 413));
  const auto long_uri = http_get(s.port, "/api/ssr?positions=" + std::string(9000, '1'));
  CHECK(long_uri.status == 414);
  const auto long_query = http_get(s.port, "/api/ssr?positions=" + std::string(3000, '1'));
  CHECK(long_query.status == 400);
  CHECK(long_query.json()["parameter"] == "query");
  CHECK(http_raw(s.port, "NONSENSE\r\n\r\n").status == 400);
}

TEST_CASE("serve API: a client past its rate gets 429 and Retry-After, others do not", "[serve]") {
  serve::ServeOptions options;
  options.rate_per_s = 2.0;
  options.burst = 4.0;
  RunningServer s(streamed().state, options);
  for (int i = 0; i < 4; ++i) REQUIRE(http_get(s.port, "/api/summary").status == 200);
  const auto refused = http_get(s.port, "/api/summary");
  CHECK(refused.status == 429);
  CHECK(refused.header("retry-after") == "1");
  CHECK(refused.json()["error"].get<std::string>().find("too many requests from 127.0.0.1: at most 2 a second "
                                                        "(bursts of 4)") != std::string::npos);
  // Another address of the loopback network is another client.
  const auto other = http_raw(s.port, "GET /api/summary HTTP/1.1\r\nHost: x\r\n\r\n", "127.0.0.2");
  CHECK(other.status == 200);
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // one token back at 2 a second
  CHECK(http_get(s.port, "/api/summary").status == 200);
}

TEST_CASE("serve API: SSR at typed positions and the damage equal predict's and damage's", "[serve][heavy]") {
  RunningServer s(streamed().state);
  const auto r = computed(s.port, "/api/ssr?positions=90:0.5:92");
  REQUIRE(r.status == 200);
  const auto j = r.json();
  CHECK(j["source"] == "posterior");
  CHECK(j["current"] == true);
  CHECK(j["checkpoint"]["seq"] == 30);
  test::TempDir out;
  const auto predict =
      test::run_ssrfleet("predict --posterior '" + streamed().state + "' --positions 90:0.5:92", out);
  REQUIRE(predict.status == 0);
  const auto rows = csv_numbers(predict.out);
  REQUIRE(rows.size() == 5);
  const char* columns[] = {"position_m", "mean_if", "lower95", "upper95", "mean_lower95", "mean_upper95"};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (int c = 0; c < 6; ++c) {
      // predict prints 10 significant digits: the same numbers agree to that.
      CHECK(j["ssr"][columns[c]][i].get<double>() == Approx(rows[i][c]).epsilon(1e-9));
    }
  }
  // Asked again: the cached result, not a second computation.
  const auto again = http_get(s.port, "/api/ssr?positions=90:0.5:92");
  CHECK(again.status == 200);
  CHECK(again.json()["compute_s"] == j["compute_s"]);

  const auto d = computed(s.port, "/api/damage");
  REQUIRE(d.status == 200);
  const auto dj = d.json();
  const auto damage = test::run_ssrfleet(
      "damage --posterior '" + streamed().state + "' --out '" + out.file("damage.csv") + "'", out);
  REQUIRE(damage.status == 0);
  const auto drows = csv_numbers(test::read_text(out.file("damage.csv")));
  REQUIRE(drows.size() == 16);
  std::size_t hot = 0;
  for (std::size_t i = 0; i < drows.size(); ++i) {
    CHECK(dj["a4"]["mean"][i].get<double>() == Approx(drows[i][5]).epsilon(1e-9));  // a4
    CHECK(dj["dlc"][i].get<double>() == Approx(drows[i][1]).epsilon(1e-9));
    hot += drows[i].back() > 0.5 ? 1 : 0;
  }
  CHECK(dj["hot_spots"].size() == hot);
}

TEST_CASE("serve: opens nothing of the state but the files it reads, and changes nothing", "[serve]") {
  const std::string state = streamed().state;
  const int watch = inotify_init1(IN_NONBLOCK);
  REQUIRE(watch >= 0);
  REQUIRE(inotify_add_watch(watch, state.c_str(), IN_ALL_EVENTS) >= 0);
  {
    RunningServer s(state);
    for (const std::string target : {"/api/summary", "/api/history", "/api/rejects", "/api/ssr", "/"}) {
      REQUIRE(http_get(s.port, target).status == 200);
    }
    computed(s.port, "/api/ssr?positions=80");
    std::this_thread::sleep_for(std::chrono::milliseconds(600));  // two polls of the state
  }
  std::set<std::string> opened, changed;
  alignas(inotify_event) char buffer[1 << 16];
  for (ssize_t n; (n = ::read(watch, buffer, sizeof buffer)) > 0;) {
    for (char* p = buffer; p < buffer + n;) {
      const auto* e = reinterpret_cast<const inotify_event*>(p);
      const std::string name = e->len > 0 ? e->name : "";
      if (e->mask & IN_OPEN) opened.insert(name);
      if (e->mask &
          (IN_MODIFY | IN_ATTRIB | IN_CREATE | IN_DELETE | IN_MOVED_FROM | IN_MOVED_TO | IN_CLOSE_WRITE)) {
        changed.insert(name);
      }
      p += sizeof(inotify_event) + e->len;
    }
  }
  ::close(watch);
  INFO("opened: " << Catch::Detail::stringify(opened) << "; changed: " << Catch::Detail::stringify(changed));
  CHECK(opened.count("lock") == 0);
  CHECK(opened.count("checkpoint.bin") == 0);
  CHECK(opened.count("trucks.bin") == 0);
  CHECK(opened.count("history.sqlite") == 1);
  // SQLite's own shared-memory files of a WAL database are the only ones a reader may write.
  for (const auto& name : changed) {
    INFO(name);
    CHECK((name == "history.sqlite-wal" || name == "history.sqlite-shm"));
  }
}

TEST_CASE("serve API: several states, each named, and without a name the answer says to give one", "[serve]") {
  site::Site site(site::load_road("AS1", nullptr), site::SiteOptions{});
  test::TempDir empty;
  serve::ServeOptions options;
  options.port = 0;
  serve::Server server({{"north", streamed().state, {{"", &site}}}, {"later", empty.file("not_yet"), {{"", &site}}}},
                       options);
  const int port = server.bind();
  std::thread thread([&] { server.run(); });
  const auto states = http_get(port, "/api/states").json()["states"];
  CHECK(states.size() == 2);
  CHECK(states[1]["name"] == "later");
  const auto unnamed = http_get(port, "/api/summary");
  CHECK(unnamed.status == 400);
  CHECK(unnamed.json()["parameter"] == "state");
  CHECK(http_get(port, "/api/summary?state=north").json()["checkpoint"]["trucks"] == 30);
  // A state whose stream has not made it yet: waiting, and 503 for what needs a checkpoint.
  const auto later = http_get(port, "/api/summary?state=later");
  CHECK(later.status == 200);
  CHECK(later.json()["status"] == "waiting");
  CHECK(later.json()["checkpoint"].is_null());
  const auto ssr = http_get(port, "/api/ssr?state=later");
  CHECK(ssr.status == 503);
  CHECK(ssr.header("retry-after") == "1");
  CHECK_FALSE(std::filesystem::exists(empty.file("not_yet")));  // nothing created on its behalf
  server.stop();
  thread.join();
}

TEST_CASE("serve: a second server on a port in use is refused, not sharing it", "[serve]") {
  RunningServer first(streamed().state);
  site::Site site(site::load_road("AS1", nullptr), site::SiteOptions{});
  serve::ServeOptions options;
  options.port = first.port;
  serve::Server second({{"site_state", streamed().state, {{"", &site}}}}, options);
  CHECK_THROWS_AS(second.bind(), IoError);
  CHECK(http_get(first.port, "/api/summary").status == 200);
}
