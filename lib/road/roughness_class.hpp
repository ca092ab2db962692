// The road roughness class of a displacement PSD level G_d(n0), n0 = 0.1 cycle/m (docs/model.md).
// Two tables, each labelled wherever a class is reported, because they disagree by one class:
//  - ISO 8608:1995 (the default; BS 7853:1996 is the same table): classes A..H, each a factor 4
//    in G_d(n0), bounds 32, 128, 512, 2048, 8192, 32768, 131072 (x 1e-6 m^3); A is open below, H
//    open above.
//  - the older ISO draft classification (ISO/TC108/SC2/WG4 N57, 1982, after Dodds & Robson 1973)
//    that the paper's labels follow ("class B" for 20e-6, "class C" for 64e-6): classes A..E with
//    bounds 8, 32, 128, 512 (x 1e-6 m^3), A open below (its nominal floor is 2e-6), E open above
//    (nominal ceiling 2048e-6).
// The same road reads a class better in the draft table than in ISO 8608:1995 (AS1's 20e-6 is B in
// the draft, A in ISO 8608). A class says nothing of the waviness w; both tables assume w = 2.
#pragma once

#include <string>
#include <string_view>

namespace ssrfleet::road {

enum class RoughnessTable { iso8608_1995, iso_draft_1982 };

struct RoughnessClass {
  std::string label;      // "A", "B", ...
  std::string table;      // the table's name as reported, e.g. "ISO 8608:1995"
  double lower_m3 = 0.0;  // the class's bounds on G_d(n0); 0 / +inf where the table is open
  double upper_m3 = 0.0;
};

// Throws std::invalid_argument unless gd_n0_m3 is positive and finite.
RoughnessClass roughness_class(double gd_n0_m3, RoughnessTable table = RoughnessTable::iso8608_1995);

// "iso8608" -> iso8608_1995, "paper" or "iso-draft-1982" -> iso_draft_1982; otherwise
// std::invalid_argument listing the names.
RoughnessTable parse_roughness_table(std::string_view name);
std::string table_name(RoughnessTable table);

}  // namespace ssrfleet::road
