// Vehicle classes: a WIM log may label each truck with a class, FHWA's 13
// ("1".."13") or the user's own. A label is plain data, a token of [A-Za-z0-9_.-]+ (so it is safe
// in a CSV field, a JSON string and a file name); an unlabelled truck has the empty label.
#pragma once

#include <string>

namespace ssrfleet::records {

// True when `label` is a class label: one or more of A-Z a-z 0-9 _ . - (and not "." or "..",
// which name directories).
inline bool is_class_label(const std::string& label) {
  if (label.empty() || label == "." || label == "..") return false;
  for (const char c : label) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

// True for FHWA's vehicle classes, the labels "1".."13" (no leading zeros).
inline bool is_fhwa_class(const std::string& label) {
  if (label.empty() || label.size() > 2 || label[0] == '0') return false;
  for (const char c : label) {
    if (c < '0' || c > '9') return false;
  }
  const int n = std::stoi(label);
  return n >= 1 && n <= 13;
}

}  // namespace ssrfleet::records
