// The one vocabulary of an options struct's IsValid (in the manner of Ceres' Solver::Options::IsValid):
// rules are checked in order, the first that fails is reported as
//   "<owner>: <name> is <value>, but must be <rule>"
// (the words of util/check.hpp's argument checks), and IsValid returns whether every rule held:
//
//   bool Options::IsValid(std::string* error) const {
//     util::OptionRules rules("TemperedSampler::Options", error);
//     rules.require(particles >= 2, "particles", particles, ">= 2");
//     rules.nested(schedule.IsValid(&why), why);
//     return rules.passed();
//   }
//
// Only the first failure is reported: later rules are still evaluated (they are cheap comparisons)
// but say nothing, so the message names the option a user should fix first.
#pragma once

#include <sstream>
#include <string>
#include <string_view>

namespace ssrfleet::util {

class OptionRules {
 public:
  // `owner` names the struct in messages; `error` (may be null) receives the first failure.
  OptionRules(std::string_view owner, std::string* error) : owner_(owner), error_(error) {}

  // A rule on one option: reports "<owner>: <name> is <value>, but must be <must>" unless `holds`.
  template <class T>
  bool require(bool holds, std::string_view name, const T& value, std::string_view must) {
    if (!holds && !failed_) {
      std::ostringstream os;
      os.precision(17);
      os << owner_ << ": " << name << " is " << value << ", but must be " << must;
      fail(os.str());
    }
    return holds;
  }
  // A rule between options, or on the struct as a whole: reports "<owner>: <text>" unless `holds`.
  bool require(bool holds, std::string_view text) {
    if (!holds && !failed_) fail(owner_ + ": " + std::string(text));
    return holds;
  }
  // A member struct's own IsValid result and message: reports "<owner>: <its message>" unless `valid`.
  bool nested(bool valid, const std::string& its_error) { return require(valid, its_error); }

  // Whether every rule held; then clears *error.
  bool passed() {
    if (!failed_ && error_ != nullptr) error_->clear();
    return !failed_;
  }

 private:
  void fail(std::string message) {
    failed_ = true;
    if (error_ != nullptr) *error_ = std::move(message);
  }

  std::string owner_;
  std::string* error_;
  bool failed_ = false;
};

}  // namespace ssrfleet::util
