// The WIM log (io/wim_log.hpp) through its incremental reader, as a stream reads it: every record
// read, each either accepted or handed back as a Rejection; the header's defects are DataErrors.
#include <sstream>

#include "fuzz_support.hpp"
#include "io/wim_log.hpp"

using namespace ssrfleet;

// Every record, read as a log of one site, then as a stream of two sites reads it (a `site` column
// naming "a", with 2 sensors, or "b", with as many as the header has: io::WimLogReader::set_sites).
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (const bool sites : {false, true}) {
    std::istringstream in{std::string(fuzz::as_text(data, size))};
    fuzz::expect_clean("log.csv", [&] {
      io::WimLogReader reader(in, "log.csv", 420.0);
      if (sites) reader.set_sites({{"a", 2}, {"b", reader.sensors()}});
      records::WimRecord record;
      io::Rejection why;
      for (;;) {
        const auto status = reader.next(record, why);
        if (status == io::WimLogReader::Status::end) break;
        if (status == io::WimLogReader::Status::record) {
          const int expected = !sites ? reader.sensors() : record.site == 0 ? 2 : reader.sensors();
          if (record.impact_factor.size() != expected || record.site > (sites ? 1u : 0u)) std::abort();
        }
        if (status == io::WimLogReader::Status::rejected && why.message.find("log.csv") == std::string::npos) std::abort();
      }
    });
  }
  return 0;
}
