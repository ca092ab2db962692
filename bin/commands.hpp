// Every subcommand: run_X(argc, argv) with argv[0] the subcommand's name. Each returns an exit
// status; only main() turns exceptions into messages.
#pragma once

namespace ssrfleet::cli {

int run_simulate(int argc, const char* const argv[]);
int run_road(int argc, const char* const argv[]);
int run_fit(int argc, const char* const argv[]);
int run_predict(int argc, const char* const argv[]);
int run_stream(int argc, const char* const argv[]);
int run_reproduce(int argc, const char* const argv[]);
int run_diagnose(int argc, const char* const argv[]);
int run_damage(int argc, const char* const argv[]);
int run_weigh(int argc, const char* const argv[]);
int run_sites(int argc, const char* const argv[]);
int run_effects(int argc, const char* const argv[]);
int run_draws(int argc, const char* const argv[]);
int run_serve(int argc, const char* const argv[]);

}  // namespace ssrfleet::cli
