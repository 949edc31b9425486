// Scene files: TOML text plus "section.key=value" overrides -> a validated Scene, and back.
// Derives the box from reduced_density, packing_fraction or explicit sides (SPEC.md section 1)
// and resolves the "auto" lattice. Every problem is collected and reported together, each
// naming the full key and the offending value (STYLE.md habit 8). scene_to_toml writes a
// canonical form that parse_scene reads back to the identical Scene. No globals, no MPI.
#include "runtime/scene.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string_view>
#include <utility>

namespace hardrod {

namespace {

// Far beyond any machine; keeps the trial-division factorisation behind "auto" instant.
constexpr long long kMaxBodies = 1'000'000'000'000;
constexpr bool kRequired = true;

struct KeySpec {
  std::string_view section;
  std::string_view name;
  bool is_string = false;  // an override value for it is taken literally, "2024" included
};

// The public key names, in canonical order.
constexpr KeySpec kKeys[] = {
    {"system", "shape", true},
    {"system", "aspect_ratio"},
    {"system", "n"},
    {"system", "reduced_density"},
    {"system", "packing_fraction"},
    {"system", "box"},
    {"init", "configuration", true},
    {"init", "lattice"},
    {"init", "axis", true},
    {"init", "file", true},
    {"init", "frame"},
    {"init", "seed"},
    {"init", "temperature"},
    {"run", "dt"},
    {"run", "equilibration_steps"},
    {"run", "steps"},
    {"run", "thermostat_interval"},
    {"run", "sample_interval"},
    {"run", "max_overlap"},
    {"run", "solver_tolerance"},
    {"run", "solver_max_iterations"},
    {"run", "skin"},
    {"output", "dir", true},
    {"output", "log_interval"},
    {"output", "snapshot_interval"},
    {"output", "checkpoint_interval"},
    {"observables", "frank"},
    {"observables", "fourier_kmax"},
    {"observables", "fourier_interval"},
};
constexpr std::string_view kSections[] = {"system", "init", "run", "output", "observables"};
constexpr std::string_view kDensityKeys[] = {"reduced_density", "packing_fraction", "box"};
constexpr std::string_view kAxisNames[] = {"x", "y", "z"};
constexpr std::string_view kConfigurations[] = {"lattice", "file",
                                                "isotropic"};  // order of Configuration

// ---- text -------------------------------------------------------------------------------

std::string full_key(std::string_view section, std::string_view name) {
  return std::string(section) + "." + std::string(name);
}

std::string join(const std::vector<std::string> &parts, std::string_view separator) {
  std::string joined;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (i > 0) joined += separator;
    joined += parts[i];
  }
  return joined;
}

std::string trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return std::string(s.substr(first, s.find_last_not_of(" \t") - first + 1));
}

// Shortest text that reads back to the same double, always recognisable as a TOML float.
std::string format_real(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  std::string text(buffer, result.ptr);
  if (std::isfinite(v) && text.find_first_of(".e") == std::string::npos) text += ".0";
  return text;
}

// For derived numbers in messages (spacings, sides): readable rather than exact.
std::string format_short(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

// A TOML basic string: quotes, backslashes and control characters escaped.
std::string quote(std::string_view s) {
  std::string quoted = "\"";
  for (const char c : s) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      quoted += '\\';
      quoted += c;
    } else if (c == '\n') {
      quoted += "\\n";
    } else if (c == '\t') {
      quoted += "\\t";
    } else if (byte < 0x20 || byte == 0x7f) {
      char escape[8];
      std::snprintf(escape, sizeof escape, "\\u%04X", byte);
      quoted += escape;
    } else {
      quoted += c;
    }
  }
  return quoted + "\"";
}

// The offending value as the user wrote it, cut short if it is long junk.
std::string describe(const toml::node &node) {
  std::string text;
  if (const auto *array = node.as_array()) {
    std::vector<std::string> items;
    for (const toml::node &item : *array) items.push_back(describe(item));
    text = "[" + join(items, ", ") + "]";
  } else if (node.is_table()) {
    text = "{...}";
  } else if (const auto *real = node.as_floating_point()) {
    text = format_real(real->get());
  } else if (const auto *integer = node.as_integer()) {
    text = std::to_string(integer->get());
  } else if (const auto *string = node.as_string()) {
    text = quote(string->get());
  } else {
    std::ostringstream out;  // booleans, dates and times
    node.visit([&out](const auto &value) { out << value; });
    text = out.str();
  }
  constexpr std::size_t kMaxShown = 60;
  return text.size() > kMaxShown ? text.substr(0, kMaxShown) + "..." : text;
}

// ---- key names and suggestions ----------------------------------------------------------

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1] ? 1 : 0)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

bool close_enough(std::size_t distance, std::string_view word) {
  return distance <= std::max<std::size_t>(2, word.size() / 3);
}

const KeySpec *find_key(std::string_view full) {
  for (const KeySpec &spec : kKeys)
    if (full_key(spec.section, spec.name) == full) return &spec;
  return nullptr;
}

// "unknown key 'run.dtt' (did you mean 'run.dt'?)"; a bare name is matched by key name.
std::string unknown_key(std::string_view full) {
  const auto dot = full.find('.');
  const std::string_view name = dot == std::string_view::npos ? full : full.substr(dot + 1);
  std::string best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const KeySpec &spec : kKeys) {
    const std::string candidate = full_key(spec.section, spec.name);
    std::size_t distance = spec.name == name ? 0 : edit_distance(full, candidate);
    if (dot == std::string_view::npos)
      distance = std::min(distance, edit_distance(name, spec.name));
    if (distance < best_distance) best_distance = distance, best = candidate;
  }
  std::string message = "unknown key '" + std::string(full) + "'";
  if (close_enough(best_distance, full)) message += " (did you mean '" + best + "'?)";
  return message;
}

std::string unknown_section(std::string_view name) {
  std::string message = "unknown section '[" + std::string(name) + "]'";
  for (const std::string_view section : kSections)
    if (close_enough(edit_distance(name, section), name))
      return message + " (did you mean '[" + std::string(section) + "]'?)";
  return message + " (sections: [system], [init], [run], [output], [observables])";
}

void check_known_keys(const toml::table &root, std::vector<std::string> &problems) {
  for (const auto &[key, node] : root) {
    const std::string_view name = key.str();
    const bool is_section =
        std::find(std::begin(kSections), std::end(kSections), name) != std::end(kSections);
    if (!is_section) {
      problems.push_back(node.is_table() ? unknown_section(name) : unknown_key(name));
    } else if (!node.is_table()) {
      problems.push_back(std::string(name) + " = " + describe(node) + ": expected a table [" +
                         std::string(name) + "]");
    } else {
      for (const auto &entry : *node.as_table()) {
        const std::string full = full_key(name, entry.first.str());
        if (!find_key(full)) problems.push_back(unknown_key(full));
      }
    }
  }
}

// ---- overrides --------------------------------------------------------------------------

// "section.key=value": value in TOML syntax, or else taken as a bare string. A density key
// replaces whichever density key the file gave, so one override can switch between them.
void apply_override(toml::table &root, const std::string &text,
                    std::vector<std::string> &problems) {
  const auto equals = text.find('=');
  if (equals == std::string::npos) {
    problems.push_back("override '" + text + "': expected section.key=value");
    return;
  }
  const std::string key = trim(std::string_view(text).substr(0, equals));
  const std::string raw = trim(std::string_view(text).substr(equals + 1));
  const KeySpec *spec = find_key(key);
  if (!spec) {
    problems.push_back("override '" + text + "': " + unknown_key(key));
    return;
  }
  if (!root.contains(spec->section)) root.insert(spec->section, toml::table{});
  toml::table *section = root.get_as<toml::table>(spec->section);
  if (!section) {
    problems.push_back("override '" + text + "': " + std::string(spec->section) +
                       " is not a table in the scene");
    return;
  }
  if (std::find(std::begin(kDensityKeys), std::end(kDensityKeys), spec->name) !=
      std::end(kDensityKeys))
    for (const std::string_view density_key : kDensityKeys) section->erase(density_key);

  toml::table parsed;
  try {
    parsed = toml::parse("value = " + raw);
  } catch (const toml::parse_error &) {
    // not a TOML value: a bare string such as runs/x
  }
  const toml::node *value = parsed.size() == 1 ? parsed.get("value") : nullptr;
  if (!value || (spec->is_string && !value->is_string())) {
    section->insert_or_assign(spec->name, raw);
  } else {
    value->visit([&](const auto &typed) { section->insert_or_assign(spec->name, typed); });
  }
}

// ---- reading values ---------------------------------------------------------------------

std::optional<long long> as_integer(const toml::node &node) {
  if (const auto *integer = node.as_integer()) return integer->get();
  if (const auto *real = node.as_floating_point()) {  // 1e8 is a fine step count
    const double v = real->get();
    if (std::isfinite(v) && v == std::trunc(v) && std::fabs(v) <= 0x1p53)
      return static_cast<long long>(v);
  }
  return std::nullopt;
}

std::optional<bool> as_boolean(const toml::node &node) {
  if (const auto *b = node.as_boolean()) return b->get();
  return std::nullopt;
}

std::optional<double> as_real(const toml::node &node) {
  if (const auto *integer = node.as_integer()) return static_cast<double>(integer->get());
  if (const auto *real = node.as_floating_point()) return real->get();
  return std::nullopt;
}

std::optional<std::string> as_string(const toml::node &node) {
  if (const auto *string = node.as_string()) return string->get();
  return std::nullopt;
}

// Typed access to the parsed table that records every problem it meets. Each get leaves
// `out` at its default when the key is absent and returns false only after a report.
class Reader {
 public:
  Reader(const toml::table &root, std::vector<std::string> &problems)
      : root_(root), problems_(problems) {}

  const toml::node *find(std::string_view section, std::string_view name) const {
    const toml::table *table = root_.get_as<toml::table>(section);
    return table ? table->get(name) : nullptr;
  }

  bool get(std::string_view section, std::string_view name, long long &out, bool required = false) {
    return fetch(section, name, out, required, as_integer, "expected an integer");
  }
  bool get(std::string_view section, std::string_view name, double &out, bool required = false) {
    return fetch(section, name, out, required, as_real, "expected a number");
  }
  bool get(std::string_view section, std::string_view name, std::string &out,
           bool required = false) {
    return fetch(section, name, out, required, as_string, "expected a string");
  }
  bool get(std::string_view section, std::string_view name, bool &out, bool required = false) {
    return fetch(section, name, out, required, as_boolean, "expected true or false");
  }

  // Reports "section.key = value: why" unless `holds`.
  bool check(std::string_view section, std::string_view name, bool holds, std::string_view why) {
    if (!holds) report(section, name, why);
    return holds;
  }
  void report(std::string_view section, std::string_view name, std::string_view why) {
    const toml::node *node = find(section, name);
    add(full_key(section, name) + " = " + (node ? describe(*node) : "(default)") + ": " +
        std::string(why));
  }
  void add(std::string problem) { problems_.push_back(std::move(problem)); }

 private:
  template <class T, class Convert>
  bool fetch(std::string_view section, std::string_view name, T &out, bool required,
             Convert convert, std::string_view expected) {
    const toml::node *node = find(section, name);
    if (!node) {
      if (required) add("missing required key '" + full_key(section, name) + "'");
      return !required;
    }
    if (std::optional<T> value = convert(*node)) {
      out = std::move(*value);
      return true;
    }
    report(section, name, expected);
    return false;
  }

  const toml::table &root_;
  std::vector<std::string> &problems_;
};

bool read_at_least(Reader &in, std::string_view section, std::string_view name, long long &out,
                   long long minimum, bool required = false) {
  return in.get(section, name, out, required) &&
         in.check(section, name, out >= minimum, "must be >= " + std::to_string(minimum));
}

// Reads a number in (low, high), or (low, high] when `high_inclusive`; NaN never passes.
bool read_between(Reader &in, std::string_view section, std::string_view name, double &out,
                  double low, double high, bool high_inclusive = false) {
  if (!in.get(section, name, out)) return false;
  const bool inside = out > low && (high_inclusive ? out <= high : out < high);
  return in.check(section, name, inside,
                  "must be in (" + format_short(low) + ", " + format_short(high) +
                      (high_inclusive ? "]" : ")"));
}

// ---- box and lattice geometry -----------------------------------------------------------

// Which earlier reads succeeded, so derived checks run only on sound inputs (no cascades).
struct Validity {
  bool shape = false, n = false, box = false, axis = false;
};

double side(const Box &box, int k) {
  return k == 0 ? box.length.x : (k == 1 ? box.length.y : box.length.z);
}

// Bodies with a common axis along `axis` do not overlap on a lattice with these spacings.
double needed_spacing(const Shape &shape, int axis, int k) {
  return k == axis ? shape.interaction_range() : shape.diameter;
}

std::string needed_name(const Shape &shape, int axis, int k) {
  return (k == axis ? "L + D = " : "D = ") + format_short(needed_spacing(shape, axis, k));
}

bool check_box_sides(Reader &in, const Scene &scene, std::string_view key, bool cubic) {
  const double range = 2.0 * scene.shape.interaction_range();
  std::vector<std::string> small;
  for (int k = 0; k < (cubic ? 1 : 3); ++k) {
    const double s = side(scene.box, k);
    if (!(std::isfinite(s) && s > range))
      small.push_back((cubic ? "cubic box side " : "side " + std::string(kAxisNames[k]) + " = ") +
                      format_short(s));
  }
  if (!small.empty())
    in.report("system", key,
              join(small, ", ") + " must exceed 2 (L + D) = " + format_short(range) +
                  " (the minimum image must be unique)");
  else if (!std::isfinite(scene.box.volume()))
    in.report("system", key, "the box volume overflows");
  return small.empty() && std::isfinite(scene.box.volume());
}

bool read_explicit_box(Reader &in, Scene &scene, const Validity &ok) {
  const toml::node &node = *in.find("system", "box");
  std::array<double, 3> sides{};
  bool parsed = false;
  if (const auto cube = as_real(node)) {
    sides = {*cube, *cube, *cube};
    parsed = true;
  } else if (const auto *array = node.as_array(); array && array->size() == 3) {
    parsed = true;
    for (int k = 0; k < 3; ++k) {
      const auto value = as_real(*array->get(k));
      parsed = parsed && value.has_value();
      sides[k] = value.value_or(0.0);
    }
  }
  if (!in.check("system", "box", parsed, "expected a number or an array of three numbers") ||
      !in.check("system", "box",
                std::all_of(sides.begin(), sides.end(),
                            [](double s) { return std::isfinite(s) && s > 0.0; }),
                "sides must be > 0 and finite"))
    return false;
  scene.box.length = {sides[0], sides[1], sides[2]};
  return ok.shape && check_box_sides(in, scene, "box", false);
}

// Exactly one of reduced_density, packing_fraction and box; a density gives a cubic box.
bool read_box(Reader &in, Scene &scene, const Validity &ok) {
  std::vector<std::string_view> given;
  for (const std::string_view key : kDensityKeys)
    if (in.find("system", key)) given.push_back(key);
  if (given.size() != 1) {
    std::vector<std::string> listed;
    listed.reserve(given.size());
    for (const std::string_view key : given)
      listed.push_back(full_key("system", key) + " = " + describe(*in.find("system", key)));
    in.add((given.empty() ? "missing required key" : join(listed, " and ")) +
           ": give exactly one of system.reduced_density, system.packing_fraction, system.box");
    return false;
  }
  const std::string_view key = given.front();
  if (key == "box") return read_explicit_box(in, scene, ok);

  double value = 0.0;
  if (!in.get("system", key, value)) return false;
  double density = 0.0;
  if (key == "reduced_density") {
    if (!in.check("system", key, value > 0.0 && value < 1.0,
                  "must be in (0, 1) (1 = close packing)"))
      return false;
    density = value * scene.shape.close_packing_density();
  } else {
    const double close = scene.shape.close_packing_density() * scene.shape.volume();
    const std::string bound = ok.shape ? format_short(close) : "close packing";
    if (!in.check("system", key, value > 0.0 && (!ok.shape || value < close),
                  "must be in (0, " + bound + ") (" + bound + " = close packing)"))
      return false;
    density = value / scene.shape.volume();
  }
  if (!ok.shape || !ok.n) return false;
  const double cube = std::cbrt(static_cast<double>(scene.n) / density);
  scene.box.length = {cube, cube, cube};
  return check_box_sides(in, scene, key, true);
}

// Counts per axis with product n that fit without overlap, the spacing over the needed
// spacing as equal as possible on the three axes; ties go to the first in lexicographic order.
std::optional<std::array<long long, 3>> auto_lattice(long long n, const Box &box,
                                                     const Shape &shape, int axis) {
  std::vector<long long> divisors;
  for (long long d = 1; d <= n / d; ++d)
    if (n % d == 0) {
      divisors.push_back(d);
      if (d != n / d) divisors.push_back(n / d);
    }
  std::sort(divisors.begin(), divisors.end());
  std::optional<std::array<long long, 3>> best;
  double best_spread = std::numeric_limits<double>::infinity();
  for (const long long nx : divisors)
    for (const long long ny : divisors) {
      if (ny > n / nx) break;
      if ((n / nx) % ny != 0) continue;
      const std::array<long long, 3> counts{nx, ny, n / nx / ny};
      double lowest = std::numeric_limits<double>::infinity(), highest = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double ratio = side(box, k) / counts[k] / needed_spacing(shape, axis, k);
        lowest = std::min(lowest, ratio);
        highest = std::max(highest, ratio);
      }
      if (lowest >= 1.0 && highest / lowest < best_spread) {
        best_spread = highest / lowest;
        best = counts;
      }
    }
  return best;
}

void read_lattice(Reader &in, Scene &scene, const Validity &ok) {
  const toml::node *node = in.find("init", "lattice");
  const bool automatic = !node || node->value<std::string>() == "auto";
  const bool geometry_ok = ok.shape && ok.box && ok.axis;
  if (automatic) {
    if (!(geometry_ok && ok.n)) return;
    if (const auto lattice = auto_lattice(scene.n, scene.box, scene.shape, scene.axis)) {
      scene.lattice = *lattice;
      return;
    }
    const int across = scene.axis == 0 ? 1 : 0;
    in.add("init.lattice = \"auto\": no lattice nx * ny * nz = " + std::to_string(scene.n) +
           " fits in the box " + format_short(side(scene.box, 0)) + " x " +
           format_short(side(scene.box, 1)) + " x " + format_short(side(scene.box, 2)) +
           " with spacing >= " + needed_name(scene.shape, scene.axis, scene.axis) + " along " +
           std::string(kAxisNames[scene.axis]) +
           " and >= " + needed_name(scene.shape, scene.axis, across) +
           " across; lower the density or change system.n");
    return;
  }
  const auto *array = node->as_array();
  bool parsed = array && array->size() == 3;
  std::array<long long, 3> counts{};
  for (int k = 0; parsed && k < 3; ++k) {
    const auto count = as_integer(*array->get(k));
    parsed = count.has_value();
    counts[k] = count.value_or(0);
  }
  if (!in.check("init", "lattice", parsed, "expected \"auto\" or an array of three integers") ||
      !in.check("init", "lattice",
                std::all_of(counts.begin(), counts.end(), [](long long c) { return c >= 1; }),
                "counts must be >= 1"))
    return;
  scene.lattice = counts;
  if (ok.n) {
    long long product = 1;
    bool overflow = false;
    for (const long long c : counts)
      overflow = overflow || __builtin_mul_overflow(product, c, &product);
    if (!in.check("init", "lattice", !overflow && product == scene.n,
                  "product " + (overflow ? std::string("overflows") : std::to_string(product)) +
                      " must equal system.n = " + std::to_string(scene.n)))
      return;
  }
  if (!geometry_ok) return;
  std::vector<std::string> overlaps;
  for (int k = 0; k < 3; ++k) {
    const double spacing = side(scene.box, k) / static_cast<double>(counts[k]);
    if (spacing < needed_spacing(scene.shape, scene.axis, k))
      overlaps.push_back("spacing along " + std::string(kAxisNames[k]) + " is " +
                         format_short(spacing) +
                         ", needs >= " + needed_name(scene.shape, scene.axis, k));
  }
  in.check("init", "lattice", overlaps.empty(),
           "bodies with their axis along " + std::string(kAxisNames[scene.axis]) +
               " overlap: " + join(overlaps, "; "));
}

// ---- the four sections ------------------------------------------------------------------

void read_system(Reader &in, Scene &scene, Validity &ok) {
  ok.shape = in.get("system", "shape", scene.shape_name) &&
             in.check("system", "shape",
                      scene.shape_name == "spherocylinder" || scene.shape_name == "sphere",
                      "must be \"spherocylinder\" or \"sphere\"");
  const bool sphere = ok.shape && scene.shape_name == "sphere";
  double aspect_ratio = sphere ? 0.0 : Shape{}.length;
  ok.shape = in.get("system", "aspect_ratio", aspect_ratio) &&
             in.check("system", "aspect_ratio", std::isfinite(aspect_ratio) && aspect_ratio >= 0.0,
                      "must be >= 0 and finite") &&
             in.check("system", "aspect_ratio", !sphere || aspect_ratio == 0.0,
                      "must be 0 (or absent) for shape = \"sphere\"") &&
             ok.shape;
  scene.shape.length = aspect_ratio * scene.shape.diameter;
  ok.n = in.get("system", "n", scene.n, kRequired) &&
         in.check("system", "n", scene.n >= 1 && scene.n <= kMaxBodies, "must be in [1, 10^12]");
  ok.box = read_box(in, scene, ok);
}

void read_init(Reader &in, Scene &scene, Validity &ok) {
  std::string axis_name = "x";
  ok.axis = in.get("init", "axis", axis_name);
  const auto axis = std::find(std::begin(kAxisNames), std::end(kAxisNames), axis_name);
  ok.axis = ok.axis &&
            in.check("init", "axis", axis != std::end(kAxisNames), "must be \"x\", \"y\" or \"z\"");
  if (ok.axis) scene.axis = static_cast<int>(axis - std::begin(kAxisNames));
  auto seed = static_cast<long long>(scene.seed);
  if (read_at_least(in, "init", "seed", seed, 0))
    scene.seed = static_cast<unsigned long long>(seed);
  in.get("init", "temperature", scene.temperature) &&
      in.check("init", "temperature", std::isfinite(scene.temperature) && scene.temperature > 0.0,
               "must be > 0 and finite");
  std::string configuration = "lattice";
  if (in.get("init", "configuration", configuration)) {
    const auto known =
        std::find(std::begin(kConfigurations), std::end(kConfigurations), configuration);
    if (in.check("init", "configuration", known != std::end(kConfigurations),
                 "must be \"lattice\", \"isotropic\" or \"file\""))
      scene.configuration = static_cast<Configuration>(known - std::begin(kConfigurations));
  }
  if (scene.configuration == Configuration::kFile) {
    in.get("init", "file", scene.init_file, kRequired) &&
        in.check("init", "file", !scene.init_file.empty(), "must name an H5MD file");
    in.get("init", "frame", scene.init_frame);
  }
  // The lattice is read (and must fit) only when the bodies start on it.
  if (scene.configuration == Configuration::kLattice) read_lattice(in, scene, ok);
}

void read_run(Reader &in, Scene &scene) {
  in.get("run", "dt", scene.dt, kRequired) &&
      in.check("run", "dt", std::isfinite(scene.dt) && scene.dt > 0.0, "must be > 0 and finite");
  read_at_least(in, "run", "equilibration_steps", scene.equilibration_steps, 0);
  read_at_least(in, "run", "steps", scene.steps, 0, kRequired);
  read_at_least(in, "run", "thermostat_interval", scene.thermostat_interval, 0);
  read_at_least(in, "run", "sample_interval", scene.sample_interval, 1);
  read_between(in, "run", "max_overlap", scene.max_overlap, 0.0, 0.5);
  read_between(in, "run", "solver_tolerance", scene.solver_tolerance, 0.0, 1.0);
  read_at_least(in, "run", "solver_max_iterations", scene.solver_max_iterations, 1);
  read_between(in, "run", "skin", scene.skin, 0.0, 2.0, true);
}

void read_output(Reader &in, Scene &scene) {
  in.get("output", "dir", scene.output_dir) &&
      in.check("output", "dir", !scene.output_dir.empty(), "must not be empty");
  read_at_least(in, "output", "log_interval", scene.log_interval, 0);
  read_at_least(in, "output", "snapshot_interval", scene.snapshot_interval, 0);
  read_at_least(in, "output", "checkpoint_interval", scene.checkpoint_interval, 0);
}

// Default fourier_kmax: the modes up to |k_a| ~ 1 D^-1 along the longest side, which cover the
// cubic fit's range (k1^2 <= 2, k3^2 <= 1 D^-2): 10 in the paper's 57 D box, 6 in a 28.5 D box.
// The cost grows as kmax^3, so a small box does not pay for modes no fit uses.
int default_fourier_kmax(const Box &box) {
  const double longest = std::max({box.length.x, box.length.y, box.length.z});
  if (!std::isfinite(longest) || !(longest > 0.0)) return 10;
  return static_cast<int>(
      std::clamp(1.0 + std::round(longest / (2.0 * std::numbers::pi)), 2.0, 64.0));
}

// The Frank-constant sampling costs nothing unless asked for.
void read_observables(Reader &in, Scene &scene) {
  in.get("observables", "frank", scene.frank);
  if (!in.find("observables", "fourier_kmax")) scene.fourier_kmax = default_fourier_kmax(scene.box);
  long long kmax = scene.fourier_kmax;
  if (read_at_least(in, "observables", "fourier_kmax", kmax, 1) &&
      in.check("observables", "fourier_kmax", kmax <= 64, "must be at most 64"))
    scene.fourier_kmax = static_cast<int>(kmax);
  read_at_least(in, "observables", "fourier_interval", scene.fourier_interval, 0);
}

}  // namespace

SceneError::SceneError(std::vector<std::string> problems)
    : std::runtime_error(join(problems, "\n")), problems_(std::move(problems)) {}

Scene parse_scene(const std::string &toml_text, const std::vector<std::string> &overrides,
                  const std::string &source_name) {
  toml::table root;
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error &error) {
    const toml::source_position where = error.source().begin;
    throw SceneError({source_name + ":" + std::to_string(where.line) + ":" +
                      std::to_string(where.column) + ": " + std::string(error.description())});
  }
  std::vector<std::string> problems;
  for (const std::string &text : overrides) apply_override(root, text, problems);
  check_known_keys(root, problems);

  Reader in(root, problems);
  Scene scene;
  Validity ok;
  read_system(in, scene, ok);
  read_init(in, scene, ok);
  read_run(in, scene);
  read_output(in, scene);
  read_observables(in, scene);
  if (!problems.empty()) throw SceneError(std::move(problems));
  return scene;
}

Scene load_scene(const std::string &path, const std::vector<std::string> &overrides) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw SceneError({path + ": is a directory, not a scene file"});
  std::ifstream file(path, std::ios::binary);
  if (!file) throw SceneError({path + ": cannot open scene file"});
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw SceneError({path + ": cannot read scene file"});
  return parse_scene(text.str(), overrides, path);
}

std::string scene_to_toml(const Scene &scene) {
  const auto &box = scene.box.length;
  std::ostringstream out;
  out << "# hardrod scene, canonical form: every value resolved, box and lattice explicit\n"
      << "[system]\n"
      << "shape = " << quote(scene.shape_name) << "\n"
      << "aspect_ratio = " << format_real(scene.shape.length / scene.shape.diameter) << "\n"
      << "n = " << scene.n << "\n"
      << "box = [" << format_real(box.x) << ", " << format_real(box.y) << ", " << format_real(box.z)
      << "]\n\n"
      << "[init]\n"
      << "configuration = " << quote(kConfigurations[static_cast<std::size_t>(scene.configuration)])
      << "\n";
  if (scene.configuration == Configuration::kLattice)
    out << "lattice = [" << scene.lattice[0] << ", " << scene.lattice[1] << ", " << scene.lattice[2]
        << "]\n";
  if (scene.configuration == Configuration::kFile)
    out << "file = " << quote(scene.init_file) << "\n"
        << "frame = " << scene.init_frame << "\n";
  out << "axis = " << quote(kAxisNames[std::clamp(scene.axis, 0, 2)]) << "\n"
      << "seed = " << scene.seed << "\n"
      << "temperature = " << format_real(scene.temperature) << "\n\n"
      << "[run]\n"
      << "dt = " << format_real(scene.dt) << "\n"
      << "equilibration_steps = " << scene.equilibration_steps << "\n"
      << "steps = " << scene.steps << "\n"
      << "thermostat_interval = " << scene.thermostat_interval << "\n"
      << "sample_interval = " << scene.sample_interval << "\n"
      << "max_overlap = " << format_real(scene.max_overlap) << "\n"
      << "solver_tolerance = " << format_real(scene.solver_tolerance) << "\n"
      << "solver_max_iterations = " << scene.solver_max_iterations << "\n"
      << "skin = " << format_real(scene.skin) << "\n\n"
      << "[output]\n"
      << "dir = " << quote(scene.output_dir) << "\n"
      << "log_interval = " << scene.log_interval << "\n"
      << "snapshot_interval = " << scene.snapshot_interval << "\n"
      << "checkpoint_interval = " << scene.checkpoint_interval << "\n\n"
      << "[observables]\n"
      << "frank = " << (scene.frank ? "true" : "false") << "\n"
      << "fourier_kmax = " << scene.fourier_kmax << "\n"
      << "fourier_interval = " << scene.fourier_interval << "\n";
  return out.str();
}

}  // namespace hardrod
