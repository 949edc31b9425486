// Scene files: TOML text plus "section.key=value" overrides -> a validated Scene. Each key's
// type and own limits come from the key table (runtime/scene_keys.hpp); this file holds the
// flow (overrides, unknown keys, the sections in order) and the rules that tie keys together:
// exactly one density key and the box derived from it (docs/physics.md section 1), and the
// lattice ("auto" resolved) that must hold n bodies without overlap. Every problem is
// collected and reported together, each naming the full key and the offending value.
// Writing the scene back is the table's too (scene_keys.cpp). No globals, no MPI.
#include "runtime/scene.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>

#include "runtime/scene_keys.hpp"
#include "runtime/scene_text.hpp"

namespace hardrod {

namespace {

using namespace scene_detail;

constexpr std::string_view kDensityKeys[] = {"reduced_density", "packing_fraction", "box"};
constexpr std::string_view kAxisNames[] = {"x", "y", "z"};

// ---- keys and overrides -----------------------------------------------------------------

void check_known_keys(const toml::table &root, std::vector<std::string> &problems) {
  for (const auto &[key, node] : root) {
    const std::string_view name = key.str();
    const bool is_section = std::ranges::find(scene_sections(), name) != scene_sections().end();
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
  if (!value || (is_string_key(*spec) && !value->is_string())) {
    section->insert_or_assign(spec->name, raw);
  } else {
    value->visit([&](const auto &typed) { section->insert_or_assign(spec->name, typed); });
  }
}

// ---- the rules between keys: box and lattice --------------------------------------------

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

// The neighbour search bins the box in cells as small as (L + D) / 2, counted in int: a box
// with more cells than kMaxCells (a needle 1e9 D long, a gas at rho* = 1e-9) is refused
// here rather than overflowing the count or the memory at the first list build.
constexpr double kMaxCells = 1 << 30;

bool check_cell_count(Reader &in, const Scene &scene, std::string_view key) {
  const double cell = 0.5 * scene.shape.interaction_range();
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) cells *= std::max(1.0, std::floor(side(scene.box, k) / cell));
  if (cells <= kMaxCells) return true;
  in.report("system", key,
            "the box holds " + format_short(cells) +
                " cells of (L + D) / 2 = " + format_short(cell) +
                " D, more than the neighbour search's 2^30; give a smaller box or a higher "
                "density");
  return false;
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
  else if (!check_cell_count(in, scene, key))
    return false;
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

// init.lattice = "auto": the lattice auto_lattice picks, or why none fits.
void read_auto_lattice(Reader &in, Scene &scene) {
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
}

// init.lattice as three counts >= 1, or nothing (the problem reported).
std::optional<std::array<long long, 3>> lattice_counts(Reader &in, const toml::node &node) {
  const auto *array = node.as_array();
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
    return std::nullopt;
  return counts;
}

// The counts' product against system.n (without overflow).
bool lattice_holds_n(Reader &in, const std::array<long long, 3> &counts, long long n) {
  long long product = 1;
  bool overflow = false;
  for (const long long c : counts)
    overflow = overflow || __builtin_mul_overflow(product, c, &product);
  return in.check("init", "lattice", !overflow && product == n,
                  "product " + (overflow ? std::string("overflows") : std::to_string(product)) +
                      " must equal system.n = " + std::to_string(n));
}

void read_lattice(Reader &in, Scene &scene, const Validity &ok) {
  const toml::node *node = in.find("init", "lattice");
  const bool geometry_ok = ok.shape && ok.box && ok.axis;
  if (!node || node->value<std::string>() == "auto") {
    if (geometry_ok && ok.n) read_auto_lattice(in, scene);
    return;
  }
  const auto counts = lattice_counts(in, *node);
  if (!counts) return;
  scene.lattice = *counts;
  if (ok.n && !lattice_holds_n(in, *counts, scene.n)) return;
  if (!geometry_ok) return;
  std::vector<std::string> overlaps;
  for (int k = 0; k < 3; ++k) {
    const double spacing = side(scene.box, k) / static_cast<double>((*counts)[k]);
    if (spacing < needed_spacing(scene.shape, scene.axis, k))
      overlaps.push_back("spacing along " + std::string(kAxisNames[k]) + " is " +
                         format_short(spacing) +
                         ", needs >= " + needed_name(scene.shape, scene.axis, k));
  }
  in.check("init", "lattice", overlaps.empty(),
           "bodies with their axis along " + std::string(kAxisNames[scene.axis]) +
               " overlap: " + join(overlaps, "; "));
}

// ---- the sections -----------------------------------------------------------------------

// The keys of one section that the table reads by themselves, in table order.
void read_section(Reader &in, std::string_view section, Scene &scene) {
  for (const KeySpec &spec : scene_keys())
    if (spec.section == section && !spec.cross) read_key(in, spec, scene);
}

Scene read_scene(Reader &in) {
  Scene scene;
  Validity ok;
  read_section(in, "system", scene);
  ok.shape = in.sound("system", "shape") && in.sound("system", "aspect_ratio");
  ok.n = in.sound("system", "n");
  ok.box = read_box(in, scene, ok);
  read_section(in, "init", scene);
  ok.axis = in.sound("init", "axis");
  // The lattice is read (and must fit) only when the bodies start on it.
  if (scene.configuration == Configuration::kLattice) read_lattice(in, scene, ok);
  read_section(in, "run", scene);
  read_section(in, "output", scene);
  read_section(in, "observables", scene);
  return scene;
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
  Scene scene = read_scene(in);
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

}  // namespace hardrod
