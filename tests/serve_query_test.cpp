// The pure parts of serve: the query parser (every refusal names its parameter), the positions
// grammar (the same positions as predict --positions), the /proc/locks reader, the quarantine
// parser and the per-client rate limit.
#include <catch2/catch.hpp>

#include "serve/query.hpp"
#include "serve/rate_limit.hpp"
#include "serve/rejects_tail.hpp"
#include "serve/stream_status.hpp"

using namespace ssrfleet::serve;

namespace {
// The parameter a QueryError names, "" if f does not throw one.
std::string refused_parameter(const std::function<void()>& f) {
  try {
    f();
  } catch (const QueryError& e) {
    return e.parameter();
  }
  return "";
}
}  // namespace

TEST_CASE("serve query: decoding, empty items and flags", "[serve]") {
  const Query q = Query::parse("state=north%20site&&positions=76%2C77.5&flag&x_y=a+b");
  REQUIRE(q.parameters().size() == 4);
  CHECK(q.get("state") == "north site");
  CHECK(q.get("positions") == "76,77.5");
  CHECK(q.get("flag") == "");
  CHECK(q.get("x_y") == "a b");
  CHECK_FALSE(q.get("absent").has_value());
  CHECK(Query::parse("").parameters().empty());
  CHECK(Query::parse("&&&").parameters().empty());
}

TEST_CASE("serve query: every refusal names the parameter", "[serve]") {
  CHECK(refused_parameter([] { Query::parse("a=1&a=2"); }) == "a");
  CHECK(refused_parameter([] { Query::parse("positions=%4"); }) == "positions");
  CHECK(refused_parameter([] { Query::parse("positions=%zz1"); }) == "positions");
  CHECK(refused_parameter([] { Query::parse("state=a%00b"); }) == "state");
  CHECK(refused_parameter([] { Query::parse(std::string("limit=1\0(", 9)); }) == "limit");
  CHECK(refused_parameter([] { Query::parse("state=a%0Ab"); }) == "state");
  CHECK(refused_parameter([] { Query::parse("Bad=1"); }) == "Bad");
  CHECK(refused_parameter([] { Query::parse("=1"); }) == "query");
  CHECK(refused_parameter([] { Query::parse(std::string(kMaxQueryBytes + 1, 'a')); }) == "query");
  CHECK(refused_parameter([] { Query::parse("v=" + std::string(kMaxValueBytes + 1, 'x')); }) == "v");
  std::string many;
  for (int i = 0; i < 17; ++i)
    many += std::string(many.empty() ? "" : "&") + "p" + std::string(i + 1, 'a') + "=1";
  // 16 parameters are fine, the 17th is named.
  CHECK(refused_parameter([&] { Query::parse(many); }) == "p" + std::string(17, 'a'));
  const Query q = Query::parse("state=s&limit=x&from=-3&cls=A%3BB&bogus=1");
  CHECK(refused_parameter([&] { q.only({"state", "limit", "from", "cls"}); }) == "bogus");
  CHECK(refused_parameter([&] { q.integer("limit", 1, 1, 50); }) == "limit");
  CHECK(refused_parameter([&] { q.integer("from", 1, 1, 50); }) == "from");
  CHECK(refused_parameter([&] { q.label("cls"); }) == "cls");
  CHECK(q.integer("absent", 7, 1, 50) == 7);
  CHECK(q.label("state") == "s");
}

TEST_CASE("serve query: positions as predict --positions computes them, bounded", "[serve]") {
  const auto p = parse_positions_value("positions", "76:0.05:98.5");
  REQUIRE(p.size() == 451);
  CHECK(p[3] == 76.0 + 3.0 * 0.05);  // FIRST + i STEP, bit for bit
  CHECK(p.back() == 76.0 + 450.0 * 0.05);
  CHECK(parse_positions_value("positions", "80,85.5,91") == std::vector<double>{80, 85.5, 91});
  CHECK(refused_parameter([] { parse_positions_value("positions", "80,80"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "80,nan"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "80,"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "1:0:5"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "5:1:1"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "1:1"); }) == "positions");
  CHECK(refused_parameter([] { parse_positions_value("positions", "0:1e-300:1e300"); }) == "positions");
  CHECK(parse_positions_value("positions", "0:1:999").size() == kMaxPositions);
  CHECK(refused_parameter([] { parse_positions_value("positions", "0:1:1000"); }) == "positions");
}

TEST_CASE("serve status: the flock holder from /proc/locks by device and inode", "[serve]") {
  const std::string locks =
      "1: POSIX  ADVISORY  WRITE 77 08:01:1234 0 EOF\n"
      "2: FLOCK  ADVISORY  WRITE 350 fd:01:1234 0 EOF\n"
      "2: -> FLOCK  ADVISORY  WRITE 351 fd:01:1234 0 EOF\n"
      "3: FLOCK  ADVISORY  WRITE 999 fd:01:99 0 EOF\n";
  CHECK(flock_holder(locks, 0xfd, 0x01, 1234) == 350);
  CHECK(flock_holder(locks, 0xfd, 0x01, 99) == 999);
  CHECK_FALSE(flock_holder(locks, 0x08, 0x01, 1234).has_value());  // a POSIX lock is not the stream's
  CHECK_FALSE(flock_holder(locks, 0xfd, 0x01, 5).has_value());
  LockState held{true, 42, true}, gone{true, std::nullopt, true}, unknown{true, std::nullopt, false};
  CHECK(stream_status(held, true, 1.0, 60.0) == "running");
  CHECK(stream_status(held, true, 61.0, 60.0) == "idle");
  CHECK(stream_status(held, false, 0.0, 60.0) == "waiting");
  CHECK(stream_status(gone, true, 1.0, 60.0) == "stopped");
  CHECK(stream_status(unknown, true, 61.0, 60.0) == "stopped");
  CHECK(stream_status(LockState{false, std::nullopt, true}, false, 0.0, 60.0) == "waiting");
}

TEST_CASE("serve rejects: line, field, reason and record, a half-written line left out", "[serve]") {
  const std::string text =
      "# records rejected by ssrfleet stream, verbatim, each after its reason\n"
      "truck_id,speed_mps\n"
      "# line 13: if_1: 'abc' is not a number\n"
      "T0011,22.5\n"
      "# line 21: speed_mps: speed 95 m/s is outside [0.5, 60]\n"
      "T0019,95\n"
      "# line 26: truck_id: duplicate truck_id 'T0023'\n"
      "T0023,19";  // no newline yet
  const auto all = parse_rejects(text, 10);
  REQUIRE(all.size() == 3);
  CHECK(all[0].line == 13);
  CHECK(all[0].field == "if_1");
  CHECK(all[0].reason == "'abc' is not a number");
  CHECK(all[0].record == "T0011,22.5");
  CHECK(all[1].reason == "speed 95 m/s is outside [0.5, 60]");
  CHECK(all[2].record.empty());
  const auto last = parse_rejects(text, 2);
  REQUIRE(last.size() == 2);
  CHECK(last[0].line == 21);
}

TEST_CASE("serve rate limit: a burst, then the refill rate, per client", "[serve]") {
  RateLimiter limit(20.0, 40.0);
  for (int i = 0; i < 40; ++i) REQUIRE(limit.take("a", 100.0) == 0.0);
  const double wait = limit.take("a", 100.0);
  CHECK(wait == Approx(0.05));            // one token at 20 a second
  CHECK(limit.take("b", 100.0) == 0.0);   // another client has its own bucket
  CHECK(limit.take("a", 100.06) == 0.0);  // 1.2 tokens back
  // A page polling every second with up to 6 requests a second never waits.
  RateLimiter page(20.0, 40.0);
  for (int s = 0; s < 600; ++s) {
    for (int r = 0; r < 6; ++r) REQUIRE(page.take("browser", 200.0 + s + 0.01 * r) == 0.0);
  }
  CHECK(RateLimiter(0.0, 0.0).take("x", 1.0) == 0.0);  // no limit
}
