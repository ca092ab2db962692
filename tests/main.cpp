// Our own Catch2 runner: it prints the random-order seed, so a failing run can be replayed
// with --rng-seed. Stochastic tests fix their own seeds; this only concerns test order.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include <iostream>

int main(int argc, char* argv[]) {
  Catch::Session session;
  if (const int rc = session.applyCommandLine(argc, argv); rc != 0) return rc;
  std::cerr << "ssrfleet tests: Catch2 rng seed " << session.config().rngSeed() << "\n";
  return session.run();
}
