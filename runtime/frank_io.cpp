// Writers and readers of the Frank data (see the header for the format).
#include "runtime/frank_io.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <utility>

namespace hardrod {

namespace {
constexpr const char *kFormat = "hardrod.frank_accumulator";
constexpr int kFormatVersion = 1;

nlohmann::json bin_row(const FrankBinKey &key, const FrankBin &v) {
  return {key.first, key.second, v.count, v.k1sq, v.k3sq,  v.k1sq_sq, v.k1sq_k3sq,
          v.k3sq_sq, v.q13,      v.q13sq, v.q23,  v.q23sq, v.self13,  v.self23};
}

FrankBlock block_from_json(const nlohmann::json &jb) {
  FrankBlock b;
  b.samples = jb.at("samples").get<long long>();
  b.sum_S2 = jb.at("sum_S2").get<double>();
  for (const auto &row : jb.at("bins")) {
    if (row.size() != 14) throw std::invalid_argument("a bin row needs 14 columns");
    FrankBin v;
    v.count = row[2].get<long long>();
    v.k1sq = row[3].get<double>(), v.k3sq = row[4].get<double>();
    v.k1sq_sq = row[5].get<double>(), v.k1sq_k3sq = row[6].get<double>();
    v.k3sq_sq = row[7].get<double>();
    v.q13 = row[8].get<double>(), v.q13sq = row[9].get<double>();
    v.q23 = row[10].get<double>(), v.q23sq = row[11].get<double>();
    v.self13 = row[12].get<double>(), v.self23 = row[13].get<double>();
    b.bins[{row[0].get<int>(), row[1].get<int>()}] = v;
  }
  return b;
}
}  // namespace

nlohmann::json to_json(const FrankAccumulator &acc) {
  nlohmann::json blocks = nlohmann::json::array();
  for (const FrankBlock &b : acc.blocks()) {
    nlohmann::json bins = nlohmann::json::array();
    for (const auto &[key, v] : b.bins) bins.push_back(bin_row(key, v));
    blocks.push_back({{"samples", b.samples}, {"sum_S2", b.sum_S2}, {"bins", std::move(bins)}});
  }
  const Box &box = acc.box();
  const FrankAccumulatorConfig &config = acc.config();
  return {{"format", kFormat},
          {"version", kFormatVersion},
          {"box", {box.length.x, box.length.y, box.length.z}},
          {"bodies", acc.bodies()},
          {"kmax", acc.kmax()},
          {"bin_width", config.bin_width},
          {"samples_per_block", config.samples_per_block},
          {"max_blocks", config.max_blocks},
          {"bin_columns",
           {"i1", "i3", "count", "k1sq", "k3sq", "k1sq_sq", "k1sq_k3sq", "k3sq_sq", "q13", "q13sq",
            "q23", "q23sq", "self13", "self23"}},
          {"blocks", std::move(blocks)}};
}

FrankAccumulator frank_accumulator_from_json(const nlohmann::json &j) {
  try {
    if (j.at("format").get<std::string>() != kFormat ||
        j.at("version").get<int>() != kFormatVersion)
      throw std::invalid_argument("not a version-1 hardrod.frank_accumulator");
    const auto &bl = j.at("box");
    FrankAccumulatorConfig config;
    config.bin_width = j.at("bin_width").get<double>();
    config.samples_per_block = j.at("samples_per_block").get<long long>();
    config.max_blocks = j.at("max_blocks").get<int>();
    FrankAccumulator acc(
        Box{{bl.at(0).get<double>(), bl.at(1).get<double>(), bl.at(2).get<double>()}},
        j.at("bodies").get<long long>(), j.at("kmax").get<int>(), config);
    for (const auto &jb : j.at("blocks")) acc.restore_block(block_from_json(jb));
    return acc;
  } catch (const nlohmann::json::exception &e) {
    throw std::invalid_argument(std::string("FrankAccumulator::from_json: ") + e.what());
  } catch (const std::invalid_argument &e) {
    throw std::invalid_argument(std::string("FrankAccumulator::from_json: ") + e.what());
  }
}

void save_frank_accumulator(const FrankAccumulator &acc, const std::string &path) {
  std::ofstream out(path);
  out << to_json(acc).dump() << '\n';
  if (!out) throw std::runtime_error("FrankAccumulator::save: cannot write " + path);
}

FrankAccumulator load_frank_accumulator(const std::string &path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("FrankAccumulator::load: cannot read " + path);
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception &e) {
    throw std::invalid_argument("FrankAccumulator::load: " + path + ": " + e.what());
  }
  return frank_accumulator_from_json(j);
}

namespace {
nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

nlohmann::json estimate_json(const FrankEstimate &e) {
  return {{"value", number_or_null(e.value)},
          {"error", number_or_null(e.error)},
          {"fit_error", number_or_null(e.fit_error)},
          {"spread", number_or_null(e.spread)}};
}

nlohmann::json model_json(const FrankModelFit &f) {
  return {{"K1", estimate_json(f.K1)},
          {"K2", estimate_json(f.K2)},
          {"K3", estimate_json(f.K3)},
          {"K3_from_E13", estimate_json(f.K3_13)},
          {"K3_from_E23", estimate_json(f.K3_23)},
          {"bins_E13", f.bins_13},
          {"bins_E23", f.bins_23},
          {"chi2_per_dof_E13", number_or_null(f.chi2_13)},
          {"chi2_per_dof_E23", number_or_null(f.chi2_23)},
          {"chi2_dof", number_or_null(f.chi2_dof())},
          {"background_E13", estimate_json(f.background_13)},
          {"background_E23", estimate_json(f.background_23)},
          {"terms_E13", f.terms_13},
          {"terms_E23", f.terms_23}};
}

nlohmann::json bin_table(const std::vector<FrankBinE> &bins) {
  nlohmann::json t = nlohmann::json::array();
  for (const FrankBinE &b : bins)
    t.push_back({b.k1sq, b.k3sq, number_or_null(b.E), number_or_null(b.error), b.count});
  return t;
}

nlohmann::json variance_json(const FrankVarianceModel &v) {
  return {{"g0", number_or_null(v.g0)}, {"g1", number_or_null(v.g1)}, {"bins", v.bins}};
}
}  // namespace

nlohmann::json to_json(const FrankResult &r) {
  const FrankFitOptions &o = r.options;
  return {{"planar", model_json(r.planar)},
          {"cubic", model_json(r.cubic)},
          {"background", model_json(r.background)},
          {"ranges",
           {{"planar_max_k2", o.planar_max_k2},
            {"cubic_max_k1sq", o.cubic_max_k1sq},
            {"cubic_max_k3sq", o.cubic_max_k3sq}}},
          {"variance_model",
           {{"E13", variance_json(r.variance_13)}, {"E23", variance_json(r.variance_23)}}},
          {"mean_S2", number_or_null(r.mean_S2)},
          {"kT", o.kT},
          {"self_term_subtracted", o.subtract_self_term},
          {"samples", r.samples},
          {"runs", r.runs},
          {"replicas", r.replicas},
          {"error_method", r.error_method},
          {"bin_columns", {"k1sq", "k3sq", "E", "error", "count"}},
          {"E13", bin_table(r.E13)},
          {"E23", bin_table(r.E23)}};
}

}  // namespace hardrod
