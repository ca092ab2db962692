#include "serve/api.hpp"

#include <cmath>
#include <sstream>

#include "damage/damage_profile.hpp"
#include "fleet/joint_sites.hpp"
#include "io/posterior_json.hpp"
#include "predict/ssr_prediction.hpp"

namespace ssrfleet::serve {

using nlohmann::json;

namespace {

// JSON has no NaN or infinity: such a value is written as null.
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json checkpoint_json(const records::HistoryReport& r) {
  return {{"seq", r.seq}, {"trucks", r.trucks}, {"time_s", r.time_s}};
}

std::shared_ptr<const Snapshot> need_snapshot(ServedState& state, ApiResponse& out) {
  auto snap = state.view().snapshot;
  if (!snap) {
    out.status = 503;
    out.body = {{"error", "the state '" + state.config().name + "' has no checkpoint yet"},
                {"parameter", "state"}};
  }
  return snap;
}

std::string check_class(const Snapshot& snap, const Query& q) {
  const auto label = q.label("class");
  if (!label) return "";
  for (const auto& c : snap.classes) {
    if (c == *label) return c;
  }
  std::string list;
  for (const auto& c : snap.classes) list.append(list.empty() ? "" : ", ").append(c.empty() ? "(none)" : c);
  throw QueryError("class", "no class '" + *label + "' in this state (its classes: " + list + ")");
}

std::size_t check_site(const ServedState& state, const Query& q) {
  const auto name = q.label("site");
  if (!name) return 0;
  const auto& sites = state.config().sites;
  for (std::size_t s = 0; s < sites.size(); ++s) {
    if (sites[s].name == *name) return s;
  }
  throw QueryError("site", "no site '" + *name + "' in this state" +
                               (sites.size() > 1 ? "" : " (a stream of one site: give no site)"));
}

// The classes of the state's posterior.json, as a job sees them, seen from site `s` of a joint
// stream, and their traffic shares; its checkpoint from its truck count.
struct PosteriorAt {
  fleet::ClassPosteriors classes;
  std::vector<double> shares;
  std::int64_t trucks = 0;
  std::uint64_t seq = 0;
};

PosteriorAt read_posterior_at(ServedState& state, std::size_t site, const std::string& only_class) {
  PosteriorAt p;
  fleet::ClassPosteriors all = io::read_posterior_classes(state.config().dir);
  for (const auto& c : all) p.trucks += c.cloud.trucks_seen;
  p.seq = state.reader().seq_of_trucks(p.trucks).value_or(0);
  // Shares from the whole stream's traffic: a young stream may not have seen every site yet.
  const std::vector<double> shares = fleet::observed_shares(all);
  for (std::size_t c = 0; c < all.size(); ++c) {
    if (!only_class.empty() && all[c].label != only_class) continue;
    if (state.config().sites.size() > 1) all[c].cloud = fleet::cloud_at_site(all[c].cloud, site);
    p.classes.push_back(std::move(all[c]));
    p.shares.push_back(only_class.empty() ? shares[c] : 1.0);
  }
  return p;
}

ApiResponse from_lookup(const Computations::Lookup& look, const Snapshot& snap) {
  ApiResponse out;
  if (look.result) {
    out.status = look.result->status;
    out.body = look.result->body;
    out.body["checkpoint"] = {{"seq", look.result->seq}, {"trucks", look.result->trucks}};
    out.body["current"] = look.result->seq >= snap.report.seq;
    out.body["compute_s"] = look.result->seconds;
    return out;
  }
  if (look.refused) {
    out.status = 503;
    out.body = {{"error", "the computation queue is full: ask again in a few seconds"},
                {"parameter", nullptr}};
    return out;
  }
  out.status = 202;
  out.body = {{"status", "computing"}, {"checkpoint", checkpoint_json(snap.report)}};
  return out;
}

json ssr_json(const predict::SsrPrediction& p) {
  json j = {{"position_m", p.position_m}, {"mean_if", json::array()},      {"lower95", json::array()},
            {"upper95", json::array()},   {"mean_lower95", json::array()}, {"mean_upper95", json::array()}};
  for (Eigen::Index i = 0; i < p.mean_if.size(); ++i) {
    j["mean_if"].push_back(number(p.mean_if[i]));
    j["lower95"].push_back(number(p.lower95[i]));
    j["upper95"].push_back(number(p.upper95[i]));
    j["mean_lower95"].push_back(number(p.mean_lower95[i]));
    j["mean_upper95"].push_back(number(p.mean_upper95[i]));
  }
  return j;
}

const json kSsrUnits = {{"position_m", "m"},   {"mean_if", "1 (impact factor)"},
                        {"lower95", "1"},      {"upper95", "1"},
                        {"mean_lower95", "1"}, {"mean_upper95", "1"}};

}  // namespace

std::string hyperparameter_unit(const std::string& name) {
  if (name == "K" || name == "sigma_k" || name == "Kt" || name == "sigma_kt") return "N/m";
  if (name == "Z" || name == "sigma_z") return "m";
  if (name == "sigma_if") return "1";
  return "";
}

json api_states(const std::vector<std::unique_ptr<ServedState>>& states) {
  json list = json::array();
  for (const auto& s : states) {
    json sites = json::array();
    for (const auto& site : s->config().sites) sites.push_back(site.name);
    list.push_back({{"name", s->config().name}, {"dir", s->config().dir}, {"sites", sites}});
  }
  return {{"states", list}};
}

ApiResponse api_summary(ServedState& state, const Query& q, double now_s, double idle_after_s) {
  q.only({"state"});
  const ServedState::View v = state.view();
  ApiResponse out;
  const bool has = v.snapshot != nullptr;
  const double age_s = has ? std::max(0.0, now_s - v.snapshot->report.time_s) : 0.0;
  const std::string status = stream_status(v.lock, has, age_s, idle_after_s);
  json sites = json::array();
  for (const auto& site : state.config().sites) sites.push_back(site.name);
  json& b = out.body;
  b = {{"state", state.config().name},
       {"status", status},
       {"lock_pid", v.lock.pid ? json(*v.lock.pid) : json(nullptr)},
       {"sites", sites},
       {"rejected", state.rejects().total()},
       {"error", v.error.empty() ? json(nullptr) : json(v.error)},
       {"units", {{"time_s", "s (Unix time)"}, {"age_s", "s"}, {"trucks_per_min", "trucks/min"}}}};
  if (!has) {
    b["checkpoint"] = nullptr;
    return out;
  }
  const Snapshot& s = *v.snapshot;
  const records::HistoryReport& r = s.report;
  b["checkpoint"] = {{"seq", r.seq},        {"trucks", r.trucks}, {"time_s", r.time_s},
                     {"age_s", age_s},      {"source", r.source}, {"lines_consumed", r.lines_consumed},
                     {"ess", number(r.ess)}};
  // Over the last minute up to now, not up to the last checkpoint: a stream that stalls shows it.
  const double span_s = std::max(now_s, r.time_s) - s.window_time_s;
  b["trucks_per_min"] =
      age_s > 60.0 || span_s < 1.0 ? 0.0 : static_cast<double>(r.trucks - s.window_trucks) / span_s * 60.0;
  b["model"] = s.model;
  b["classes"] = s.classes;
  json hyper = json::array();
  for (const auto& h : r.hyperparameters) {
    hyper.push_back({{"class", h.vehicle_class},
                     {"name", h.name},
                     {"unit", hyperparameter_unit(h.name)},
                     {"mean", number(h.mean)},
                     {"sd", number(h.sd)},
                     {"q025", number(h.q025)},
                     {"q975", number(h.q975)}});
  }
  b["hyperparameters"] = hyper;
  return out;
}

ApiResponse api_history(ServedState& state, const Query& q) {
  q.only({"state", "class", "param", "from", "to", "points"});
  ApiResponse out;
  const auto snap = need_snapshot(state, out);
  if (!snap) return out;
  HistoryQuery h;
  h.max_seq = snap->report.seq;
  h.vehicle_class = check_class(*snap, q);
  if (const auto param = q.get("param"); param && !param->empty()) {
    bool known = false;
    for (const auto& row : snap->report.hyperparameters) known = known || row.name == *param;
    if (!known) throw QueryError("param", "no hyperparameter '" + param->substr(0, 64) + "' in this state");
    h.name = *param;
  }
  h.from_trucks = q.integer("from", 1, 1, snap->report.trucks);
  h.to_trucks = q.integer("to", snap->report.trucks, h.from_trucks, std::numeric_limits<std::int64_t>::max());
  h.points = static_cast<int>(q.integer("points", 400, 2, 2000));
  json series = json::array();
  for (const auto& s : state.reader().history(h)) {
    json means = json::array(), lo = json::array(), hi = json::array();
    for (std::size_t i = 0; i < s.trucks.size(); ++i) {
      means.push_back(number(s.mean[i]));
      lo.push_back(number(s.q025[i]));
      hi.push_back(number(s.q975[i]));
    }
    series.push_back({{"name", s.name},
                      {"unit", hyperparameter_unit(s.name)},
                      {"trucks", s.trucks},
                      {"mean", means},
                      {"q025", lo},
                      {"q975", hi}});
  }
  out.body = {{"checkpoint", checkpoint_json(snap->report)},
              {"class", h.vehicle_class},
              {"series", series},
              {"units", {{"trucks", "trucks absorbed"}, {"mean", "the parameter's unit"}}}};
  return out;
}

ApiResponse api_rejects(ServedState& state, const Query& q) {
  q.only({"state", "limit"});
  const auto limit = static_cast<std::size_t>(q.integer("limit", 20, 1, 50));
  ApiResponse out;
  json list = json::array();
  for (const auto& r : state.rejects().last(limit)) {
    list.push_back({{"line", r.line}, {"field", r.field}, {"reason", r.reason}, {"record", r.record}});
  }
  out.body = {{"rejected", state.rejects().total()}, {"last", list}};
  return out;
}

ApiResponse api_ssr(ServedState& state, std::size_t state_index, const Query& q, Computations& computations) {
  q.only({"state", "positions", "class", "site"});
  ApiResponse out;
  const auto snap = need_snapshot(state, out);
  if (!snap) return out;
  const std::string cls = check_class(*snap, q);
  const std::size_t site = check_site(state, q);
  const std::vector<double> positions = q.positions("positions");
  const std::string site_name = state.config().sites[site].name;
  if (positions.empty() && q.label("class") == std::nullopt && site == 0) {
    // The history's own prediction at the sensors: no computation at all.
    json j = {{"position_m", json::array()},   {"mean_if", json::array()},
              {"lower95", json::array()},      {"upper95", json::array()},
              {"mean_lower95", json::array()}, {"mean_upper95", json::array()}};
    for (const auto& p : snap->report.predictions) {
      j["position_m"].push_back(p.position_m);
      j["mean_if"].push_back(number(p.mean_if));
      j["lower95"].push_back(number(p.lower95));
      j["upper95"].push_back(number(p.upper95));
      j["mean_lower95"].push_back(number(p.mean_lower95));
      j["mean_upper95"].push_back(number(p.mean_upper95));
    }
    out.body = {{"ssr", j},           {"source", "history"},
                {"site", site_name},  {"class", cls},
                {"units", kSsrUnits}, {"checkpoint", checkpoint_json(snap->report)},
                {"current", true},    {"prediction", {{"theta_draws", 50}, {"trucks_per_draw", 40}}}};
    return out;
  }
  std::ostringstream key;
  key.precision(17);
  key << state_index << "|ssr|" << cls << "|" << site << "|";
  for (const double p : positions) key << p << ",";
  ServedState* st = &state;
  auto job = [st, site, cls, positions, site_name](
                 const std::shared_ptr<const ComputeResult>& have) -> std::shared_ptr<const ComputeResult> {
    PosteriorAt p = read_posterior_at(*st, site, cls);
    if (have && have->seq == p.seq && p.seq != 0) return nullptr;  // this checkpoint is done already
    const site::Site& where = *st->config().sites[site].site;
    const predict::PredictionOptions options;  // predict's defaults: the same numbers as ssrfleet predict
    const predict::SsrPrediction prediction =
        predict::predict_ssr_mixture(p.classes, p.shares, where, positions, options);
    auto r = std::make_shared<ComputeResult>();
    r->seq = p.seq;
    r->trucks = p.trucks;
    r->body = {{"ssr", ssr_json(prediction)},
               {"source", "posterior"},
               {"site", site_name},
               {"class", cls},
               {"units", kSsrUnits},
               {"prediction",
                {{"theta_draws", options.theta_draws},
                 {"trucks_per_draw", options.trucks_per_draw},
                 {"seed", options.seed}}}};
    return r;
  };
  return from_lookup(computations.request(key.str(), snap->report.seq, job), *snap);
}

ApiResponse api_damage(ServedState& state, std::size_t state_index, const Query& q,
                       Computations& computations) {
  q.only({"state", "positions", "class", "site"});
  ApiResponse out;
  const auto snap = need_snapshot(state, out);
  if (!snap) return out;
  const std::string cls = check_class(*snap, q);
  const std::size_t site = check_site(state, q);
  const std::vector<double> positions = q.positions("positions");
  const std::string site_name = state.config().sites[site].name;
  std::ostringstream key;
  key.precision(17);
  key << state_index << "|damage|" << cls << "|" << site << "|";
  for (const double p : positions) key << p << ",";
  ServedState* st = &state;
  auto job = [st, site, cls, positions, site_name](
                 const std::shared_ptr<const ComputeResult>& have) -> std::shared_ptr<const ComputeResult> {
    PosteriorAt p = read_posterior_at(*st, site, cls);
    if (have && have->seq == p.seq && p.seq != 0) return nullptr;
    const site::Site& where = *st->config().sites[site].site;
    const damage::DamageOptions options;  // damage's defaults, as ssrfleet damage computes them
    const records::DamageProfile d =
        damage::predict_damage_mixture(p.classes, p.shares, where, positions, options);
    json a4 = {{"mean", json::array()}, {"q025", json::array()}, {"q975", json::array()}};
    json hot = json::array(), dlc = json::array(), esal = json::array();
    for (std::size_t i = 0; i < d.position_m.size(); ++i) {
      a4["mean"].push_back(number(d.powers[1].mean[i]));
      a4["q025"].push_back(number(d.powers[1].q025[i]));
      a4["q975"].push_back(number(d.powers[1].q975[i]));
      dlc.push_back(number(d.dlc[i]));
      esal.push_back(number(d.esal_per_million[i]));
      if (d.hot_spot[i]) {
        hot.push_back({{"position_m", d.position_m[i]},
                       {"a4", number(d.powers[1].mean[i])},
                       {"a4_q975", number(d.powers[1].q975[i])},
                       {"esal_per_million", number(d.esal_per_million[i])}});
      }
    }
    auto r = std::make_shared<ComputeResult>();
    r->seq = p.seq;
    r->trucks = p.trucks;
    r->body = {{"position_m", d.position_m},
               {"a4", a4},
               {"dlc", dlc},
               {"esal_per_million", esal},
               {"static_esal_per_million", number(d.static_esal_per_million)},
               {"hot_spot_threshold", d.hot_spot_threshold},
               {"hot_spots", hot},
               {"site", site_name},
               {"class", cls},
               {"units",
                {{"position_m", "m"},
                 {"a4", "1 (E[IF^4]; 1 = static)"},
                 {"dlc", "1"},
                 {"esal_per_million", "equivalent standard axles (80 kN) per million trucks"}}}};
    return r;
  };
  return from_lookup(computations.request(key.str(), snap->report.seq, job), *snap);
}

}  // namespace ssrfleet::serve
