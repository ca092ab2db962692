// The WIM log (io/wim_log.hpp) through its incremental reader, as a stream reads it: every record
// read, each either accepted or handed back as a Rejection; the header's defects are DataErrors.
#include <sstream>

#include "fuzz_support.hpp"
#include "io/wim_log.hpp"

using namespace ssrfleet;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in{std::string(fuzz::as_text(data, size))};
  fuzz::expect_clean("log.csv", [&] {
    io::WimLogReader reader(in, "log.csv", 420.0);
    records::WimRecord record;
    io::Rejection why;
    for (;;) {
      const auto status = reader.next(record, why);
      if (status == io::WimLogReader::Status::end) break;
      if (status == io::WimLogReader::Status::record && record.impact_factor.size() != reader.sensors()) std::abort();
      if (status == io::WimLogReader::Status::rejected && why.message.find("log.csv") == std::string::npos) std::abort();
    }
  });
  return 0;
}
