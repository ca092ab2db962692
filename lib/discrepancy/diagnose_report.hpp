// What `ssrfleet diagnose` shows: the JSON report (the contract other tools read), a text
// summary for the terminal, and the per-sensor CSVs with their gnuplot renderings.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "discrepancy/diagnose.hpp"

namespace ssrfleet::discrepancy {

// {"effect": NAME|"none", "parameters": {...}, "log_bayes_factor": x, "gap_before": {...},
//  "gap_after": {...}, "candidates": [...], "checks_before": [...], "checks_after": [...], ...}
nlohmann::json diagnosis_to_json(const DiagnoseResult& result);

// The verdict, the checks before and after, the candidates and the gap, as text tables.
void print_diagnosis(std::ostream& os, const DiagnoseResult& result);

// Writes residual_pattern.csv, checks.csv, per_sensor_checks.csv, summary.md, report.json and
// the gnuplot scripts into dir (created if missing), and renders the plots when `plots` and
// gnuplot is on PATH. Returns the files written (relative to dir); IoError if dir cannot be
// written. *plotted (if given) says whether gnuplot ran without failure.
std::vector<std::string> write_diagnosis_files(const std::string& dir, const DiagnoseResult& result, bool plots,
                                               bool* plotted = nullptr);

}  // namespace ssrfleet::discrepancy
