#include <ostream>

#include "cli_common.hpp"
#include "process_ranks.hpp"
#include "fit_methods.hpp"
#include "fleet/posterior_summary.hpp"
#include "fleet/vehicle_classes.hpp"
#include "io/posterior_json.hpp"

namespace ssrfleet::cli {

fleet::ClassPosteriors fit_classes_to_file(const std::vector<records::WimRecord>& records, std::uint64_t seed, const std::string& out,
                         std::ostream* progress,
                         const std::function<fleet::PosteriorCloud(const std::vector<records::WimRecord>&, std::uint64_t)>& fit_class) {
  fleet::ClassPosteriors classes;
  std::vector<std::vector<fleet::ParameterSummary>> hyper, psi;
  for (const auto& [label, class_records] : fleet::split_by_class(records)) {
    const std::uint64_t class_seed = fleet::class_seed(seed, label);
    if (progress && !label.empty()) {
      *progress << "ssrfleet fit: class " << label << ": " << class_records.size() << " trucks, seed " << class_seed << "\n";
    }
    fleet::PosteriorCloud cloud = fit_class(class_records, class_seed);
    hyper.push_back(fleet::summarise_cloud(cloud));
    psi.push_back(fleet::summarise_psi(cloud));
    classes.push_back({label, std::move(cloud)});
  }
  if (process_ranks().rank() != 0) return classes;  // rank 0 writes for every rank (the ranks hold the same posterior)
  write_output(out, [&](std::ostream& os) { os << io::posterior_file_text(io::posterior_classes_to_json(classes, hyper, psi)); });
  return classes;
}

}  // namespace ssrfleet::cli
