// The stop token (util/stop_token.hpp): a call given a token stops with Stopped within a second of
// the token being tripped from another thread, and a token never tripped (or none) changes nothing.
#include <chrono>
#include <future>
#include <thread>

#include <catch2/catch.hpp>

#include "fleet/batch_mcmc_chains.hpp"
#include "fleet/online_fit.hpp"
#include "fleet/replay.hpp"
#include "simulated_case.hpp"
#include "util/stop_token.hpp"

using namespace ssrfleet;

namespace {
using Clock = std::chrono::steady_clock;

// Runs `work` on a thread of its own under `token`, trips the token after `delay_s`, and returns
// the seconds from the trip to the call's end; `threw` says whether it ended with Stopped.
template <typename Work>
double stop_after(double delay_s, Work work, bool& threw) {
  util::StopToken token;
  std::promise<Clock::time_point> ended;
  std::future<Clock::time_point> end = ended.get_future();
  threw = false;
  std::thread driver([&] {
    const util::StopScope scope(&token);
    try {
      work();
    } catch (const util::Stopped&) {
      threw = true;
    }
    ended.set_value(Clock::now());
  });
  std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
  const Clock::time_point tripped = Clock::now();
  token.request_stop();
  const Clock::time_point at = end.get();
  driver.join();
  return std::chrono::duration<double>(at - tripped).count();
}

fleet::OnlineFitOptions smc_options(long particles) {
  fleet::OnlineFitOptions o;  // the marginal core, as `ssrfleet fit` runs it
  o.sampler().particles = particles;
  o.sampler().threads = 2;
  o.sampler().seed = 5;
  return o;
}
}  // namespace

TEST_CASE("a token is only the calling thread's, scopes nest, and an untripped token never throws",
          "[util][stop]") {
  CHECK(util::current_stop_token() == nullptr);
  CHECK_NOTHROW(util::throw_if_stopped());
  util::StopToken outer, inner;
  {
    const util::StopScope a(&outer);
    CHECK(util::current_stop_token() == &outer);
    {
      const util::StopScope b(&inner);
      inner.request_stop();
      CHECK(util::stop_requested());
      CHECK_THROWS_AS(util::throw_if_stopped(), util::Stopped);
      // Another thread has no token, whatever this one has.
      bool elsewhere = true;
      std::thread([&] {
        elsewhere = util::current_stop_token() != nullptr || util::stop_requested();
      }).join();
      CHECK_FALSE(elsewhere);
    }
    CHECK(util::current_stop_token() == &outer);
    CHECK_FALSE(util::stop_requested());
    CHECK_NOTHROW(util::throw_if_stopped());
  }
  CHECK(util::current_stop_token() == nullptr);
}

TEST_CASE("an SMC fit stops with Stopped within a second of its token being tripped", "[util][stop][timing]") {
  const test::SimulatedCase c(400, 3);
  const auto options = smc_options(4096);  // far more than 0.3 s of work on two cores
  bool threw = false;
  const Clock::time_point started = Clock::now();
  const double after_trip_s = stop_after(
      0.3,
      [&] {
        auto fit = fleet::make_online_fit(c.site, options);
        fleet::replay(*fit, c.log.records, {});
      },
      threw);
  const double total_s = std::chrono::duration<double>(Clock::now() - started).count();
  INFO("ended " << after_trip_s << " s after the trip, " << total_s << " s in all");
  CHECK(threw);
  CHECK(after_trip_s < 1.0);
}

TEST_CASE("batch MCMC chains on threads of their own stop within a second of the caller's token",
          "[util][stop][timing]") {
  const test::SimulatedCase c(60, 4);
  fleet::BatchMcmcChainsOptions o;
  o.chains = 3;
  o.chain.iterations = 50'000'000;  // hours, unless stopped
  o.chain.burn_in = 100;
  o.chain.thin = 100;
  o.chain.seed = 2;
  o.chain.threads = 2;
  bool threw = false;
  const double after_trip_s = stop_after(
      0.3, [&] { fleet::run_batch_mcmc_chains(c.site, c.log.records, o); }, threw);
  INFO("ended " << after_trip_s << " s after the trip");
  CHECK(threw);
  CHECK(after_trip_s < 1.0);
}

TEST_CASE("a fit under a token never tripped gives the bits of a fit without one", "[util][stop]") {
  const test::SimulatedCase c(12, 6);
  const auto options = smc_options(128);
  auto plain = fleet::make_online_fit(c.site, options);
  fleet::replay(*plain, c.log.records, {});
  util::StopToken token;
  const util::StopScope scope(&token);
  auto watched = fleet::make_online_fit(c.site, options);
  fleet::replay(*watched, c.log.records, {});
  const fleet::PosteriorCloud a = plain->cloud(), b = watched->cloud();
  REQUIRE(a.theta.cols() >= 128);  // the particles, or the final sweeps' clouds pooled
  REQUIRE(b.theta.cols() == a.theta.cols());
  CHECK(a.theta.cwiseEqual(b.theta).all());
  CHECK(a.weights.cwiseEqual(b.weights).all());
  CHECK(a.log_evidence == b.log_evidence);

  fleet::BatchMcmcChainsOptions m;
  m.chains = 2;
  m.chain.iterations = 400;
  m.chain.burn_in = 100;
  m.chain.seed = 8;
  m.chain.threads = 2;
  const auto with = fleet::run_batch_mcmc_chains(c.site, c.log.records, m);
  const util::StopScope none(nullptr);
  const auto without = fleet::run_batch_mcmc_chains(c.site, c.log.records, m);
  for (std::size_t k = 0; k < 2; ++k) CHECK(with[k].theta_draws == without[k].theta_draws);
}
