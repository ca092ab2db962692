// ssrfleet effects: the effect catalogue (lib/model/effects, read through the registry of
// model/model_extension.hpp): each effect's name, what it models, its parameters with units,
// ranges and base-model values, the checks of diagnose that point at it, and how a model spec
// names effects. Ranges can depend on the site (the sensor count, the sensors' positions), so
// they are printed for the site the options describe (AS1 and the default sensors unless given).
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "help_format.hpp"
#include "model/model_extension.hpp"
#include "site/road_source.hpp"

namespace ssrfleet::cli {

namespace {

// What each effect models, in more words than its one-line description; an effect added to the
// catalogue without an entry here shows its description alone.
const std::map<std::string, std::string>& explanations() {
  static const std::map<std::string, std::string> text = {
      {"profile_defect",
       "A local bump (height > 0) or dip (height < 0) across the whole lane that the road file does not "
       "have: a patch, a joint, settlement over a culvert. Its shape is a raised cosine `length` long "
       "centred at `position`, smoothed by the site's tyre envelopment like the rest of the road. It may sit "
       "anywhere from 20 m before the first sensor to the last sensor (a defect after the last sensor cannot "
       "be seen). Height 0 is the base model, whatever the position and length."},
      {"second_class",
       "The fleet is two classes of truck (say steel and air suspensions): a share of them, at most half, "
       "has its own suspension stiffness distribution N(K2, sigma_k2^2). It changes the fleet model, not the "
       "quarter car, so the residuals show nothing; the trucks' fitted stiffnesses do not look like draws "
       "from one normal distribution. A share of 0 is the base model, whatever K2 and sigma_k2."},
      {"sensor_gain",
       "One sensor's calibration gain is not 1: it reports gain x the true impact factor. Which sensor is "
       "inferred too: `sensor` is continuous and the sensor is its nearest whole number, so the fit can move "
       "between sensors."},
      {"speed_bias",
       "The WIM system's speeds are biased by a factor (logged = factor x true), so the truck really drove "
       "at logged / factor and the road excited it at other frequencies."},
      {"suspension_damping",
       "The suspension's viscous damping c_b differs from the value the site assumes (--cb). It sets how "
       "long body bounce rings on after a disturbance."},
      {"tyre_damping",
       "The tyre dissipates energy: its damping c_t differs from the value the site assumes (--ct, 0 in the "
       "paper). It damps the axle's hop at 8-12 Hz, so the effect is largest where the road excites the "
       "axle."},
      {"unsprung_mass",
       "The axle's mass m1 differs from the value the site assumes (--m1). It moves the axle-hop frequency, "
       "and with it the pattern of dynamic force along the road."},
  };
  return text;
}

void print_effect(std::ostream& os, const fleet::ModelExtension& effect, int width) {
  os << wrap(effect.name() + ": " + effect.description(), width, 2, 0) << "\n";
  const auto known = explanations().find(effect.name());
  if (known != explanations().end()) os << "    " << wrap(known->second, width, 4, 4) << "\n";
  std::vector<HelpRow> rows;
  for (const auto& p : effect.parameters()) {
    rows.push_back({"  " + p.name, (p.unit.empty() ? std::string("no unit") : p.unit) + "; in [" +
                                       shortest_text(p.lo) + ", " + shortest_text(p.hi) + "]; null value " +
                                       shortest_text(p.null_value)});
  }
  os << "  parameters:\n" << format_rows(rows, width, 24);
  std::string checks;
  for (const auto kind : effect.signature())
    checks += (checks.empty() ? "" : ", ") + std::string(fleet::check_name(kind));
  os << "  " << wrap("diagnose's checks that point at it: " + checks, width, 4, 2) << "\n";
}

}  // namespace

int run_effects(int argc, const char* const argv[]) {
  std::string road = "AS1";
  SiteFlags site_flags;
  po::options_description desc("effects options");
  desc.add_options()("help,h", "show this help")(
      "road", po::value(&road)->value_name("ROAD")->default_value(road),
      std::string(kRoadHelp)
          .append(": the ranges of a parameter that depends on the site are this site's")
          .c_str());
  site_flags.add_to(desc);
  po::variables_map vm;
  if (!parse_or_help(argc, argv, desc, nullptr, vm,
                     "ssrfleet effects [--road ROAD] [--sensors FIRST,SPACING,COUNT]",
                     "Each effect is a physical effect that the base model (the paper's quarter car on the "
                     "road file, with the site's vehicle constants) leaves out. A parameter that a model "
                     "spec leaves out is fitted, with a uniform prior over its range; at its null values the "
                     "effect vanishes and the model is the base model.")) {
    return 0;
  }
  const site::Site site(site::load_road(road, &std::cerr), site_flags.to_options());
  const int width = help_width();
  std::ostream& os = std::cout;
  os << wrap(
            "The effect catalogue: physical effects the base model leaves out, for fit --model, stream "
            "--model, "
            "reproduce --model, simulate --model and diagnose --candidates. A parameter left out of a spec "
            "is fitted, with a uniform prior over its range; at its null values the effect vanishes (the "
            "base model). Ranges for road " +
                site.surface().name + " with sensors " + site_flags.sensors +
                " (--road and --sensors give another site's).",
            width, 0, 0)
     << "\n\n";
  os << "Model specs:\n"
     << format_rows({{"base", "the base model (the paper's), no effect"},
                     {"NAME", "one effect, every parameter fitted"},
                     {"NAME:PARAM=VALUE,...",
                      "one effect, the parameters given fixed at their values, the rest fitted"},
                     {"SPEC+SPEC+...",
                      "several effects at once, each named once (at most one that replaces the fleet's "
                      "stiffness distribution, such as second_class)"}},
                    width, 26)
     << "\n";
  os << wrap(
            "For example tyre_damping+sensor_gain:sensor=11 fits tyre damping and a gain on sensor 11; "
            "sensor_gain:sensor=5,gain=1.05 fits nothing (the effect known). simulate --model needs every "
            "parameter given; diagnose --candidates takes names alone, comma-separated.",
            width, 0, 0)
     << "\n\nEffects:\n";
  for (const auto& name : fleet::extension_names()) {
    os << "\n";
    print_effect(os, *fleet::make_extension(name, site), width);
  }
  return 0;
}

}  // namespace ssrfleet::cli
