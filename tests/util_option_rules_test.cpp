// The options' one checking vocabulary (util/option_rules.hpp): the first failing rule is the one
// reported, in the words of the argument checks, and a struct's IsValid says which option to fix.
#include <string>

#include <catch2/catch.hpp>

#include "fleet/batch_mcmc.hpp"
#include "fleet/batch_mcmc_chains.hpp"
#include "smc/engine.hpp"
#include "smc/move_schedule.hpp"
#include "util/option_rules.hpp"

using ssrfleet::util::OptionRules;

TEST_CASE("option rules report the first failure only, in one form, and clear the message when all hold",
          "[util][options]") {
  std::string error = "left over";
  {
    OptionRules rules("Owner", &error);
    CHECK(rules.require(true, "a", 1, ">= 1"));
    CHECK(rules.passed());
    CHECK(error.empty());
  }
  {
    OptionRules rules("Owner", &error);
    CHECK_FALSE(rules.require(2.5 < 0.0, "scale", 2.5, "negative"));
    CHECK_FALSE(rules.require(false, "threads", 0, ">= 1"));  // a second failure is not reported
    CHECK_FALSE(rules.passed());
    CHECK(error == "Owner: scale is 2.5, but must be negative");
  }
  {
    OptionRules rules("Owner", &error);
    rules.require(true, "first", 1, "anything");
    rules.nested(false, "Inner: depth is 0, but must be >= 1");
    CHECK_FALSE(rules.passed());
    CHECK(error == "Owner: Inner: depth is 0, but must be >= 1");
  }
  OptionRules silent("Owner", nullptr);  // a caller that only wants the verdict
  CHECK_FALSE(silent.require(false, "a rule between options"));
  CHECK_FALSE(silent.passed());
}

TEST_CASE("the sampler's, the schedule's and the batch MCMC's options name the option a user must fix",
          "[util][options]") {
  std::string error;
  ssrfleet::smc::TemperedSampler::Options sampler;
  CHECK(sampler.IsValid(&error));
  CHECK(error.empty());
  sampler.particles = 1;
  sampler.threads = 0;  // also wrong, but reported only once the particles are fixed
  CHECK_FALSE(sampler.IsValid(&error));
  CHECK(error == "TemperedSampler::Options: particles is 1, but must be >= 2");
  sampler.particles = 64;
  CHECK_FALSE(sampler.IsValid(&error));
  CHECK(error == "TemperedSampler::Options: threads is 0, but must be >= 1");
  sampler.threads = 1;
  sampler.schedule.max_sweeps = sampler.schedule.min_sweeps - 1;
  CHECK_FALSE(sampler.IsValid(&error));
  CHECK(error.rfind("TemperedSampler::Options: MoveSchedule: max_sweeps is ", 0) == 0);

  ssrfleet::fleet::BatchMcmcChainsOptions chains;
  chains.chains = 65;
  CHECK_FALSE(chains.IsValid(&error));
  CHECK(error == "BatchMcmcChainsOptions: chains is 65, but must be in [1, 64]");
  chains.chains = 4;
  chains.chain.burn_in = chains.chain.iterations;
  CHECK_FALSE(chains.IsValid(&error));
  CHECK(error.rfind("BatchMcmcChainsOptions: BatchMcmcOptions: burn_in is ", 0) == 0);
  CHECK(error.find("or no draw is kept") != std::string::npos);
}
