// The scene-key table and what interprets it one key at a time: reading a key, its text in
// the canonical scene, suggestions for unknown keys (see scene_keys.hpp).
#include "runtime/scene_keys.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace hardrod::scene_detail {

namespace {

// Far beyond any machine; keeps the trial-division factorisation behind "auto" instant.
constexpr long long kMaxBodies = 1'000'000'000'000;
// The most steps a run may hold (equilibration and production together), and so the largest
// interval: decades at a microsecond per step, and far enough from 2^63 that the run loop's
// step arithmetic (sums of a step and an interval) cannot overflow.
constexpr long long kMaxSteps = 1'000'000'000'000'000;

constexpr std::string_view kSections[] = {"system", "init", "run", "output", "observables"};
constexpr std::string_view kShapes[] = {"spherocylinder", "sphere"};
constexpr std::string_view kConfigurations[] = {"lattice", "file", "isotropic"};  // enum order
constexpr std::string_view kAxisNames[] = {"x", "y", "z"};
constexpr std::string_view kMethods[] = {"midpoint", "exact"};  // Method order
// What a value of each Type must be, in the order of Type (for the reference).
constexpr std::string_view kTypeNames[] = {"integer",
                                           "number",
                                           "string",
                                           "string",
                                           "true or false",
                                           "number or [3 numbers]",
                                           "\"auto\" or [3 integers]"};

constexpr Limit at_least(long long min) { return {.kind = Limit::Kind::kIntegers, .min = min}; }
constexpr Limit integers(long long min, long long max, std::string_view why = {}) {
  return {.kind = Limit::Kind::kIntegers, .min = min, .max = max, .why = why};
}
constexpr Limit positive() { return {.kind = Limit::Kind::kPositive}; }
constexpr Limit non_negative() { return {.kind = Limit::Kind::kNonNegative}; }
constexpr Limit between(double low, double high) {
  return {.kind = Limit::Kind::kOpen, .low = low, .high = high};
}
constexpr Limit between_closed(double low, double high) {
  return {.kind = Limit::Kind::kOpenClosed, .low = low, .high = high};
}
constexpr Limit non_empty(std::string_view why) {
  return {.kind = Limit::Kind::kNonEmpty, .why = why};
}
constexpr Limit one_of(std::span<const std::string_view> choices, std::string_view why) {
  return {.kind = Limit::Kind::kOneOf, .why = why, .choices = choices};
}

constexpr Limit steps_limit() { return integers(0, kMaxSteps); }

// Production comes after equilibration: their sum is the last step, within kMaxSteps.
std::string_view total_steps_fit(const Scene &s, const Value &v) {
  return std::get<long long>(v) > kMaxSteps - s.equilibration_steps
             ? "run.equilibration_steps + run.steps must be at most 1000000000000000"
             : "";
}

bool lattice_start(const Scene &s) { return s.configuration == Configuration::kLattice; }
bool file_start(const Scene &s) { return s.configuration == Configuration::kFile; }
bool isotropic_start(const Scene &s) { return s.configuration == Configuration::kIsotropic; }

// The exact method's bounds grow by a whole step's flight at dt ~1e-3 before every step: a
// wider skin rebuilds less often, a too wide one lists more pairs. The cheapest, measured in
// turns (docs/performance.md): about 1.0 D for the nematic, anywhere from 0.3 to 0.6 D for
// hard spheres.
constexpr double kExactSkinRods = 1.0, kExactSkinSpheres = 0.6;
void skin_for_method(Scene &s) {
  if (s.method == kExact) s.skin = s.shape_name == "sphere" ? kExactSkinSpheres : kExactSkinRods;
}

// A sphere has L = 0: its aspect ratio defaults to 0 and may not be anything else.
void sphere_has_no_length(Scene &s) {
  if (s.shape_name == "sphere") s.shape.length = 0.0;
}
std::string_view aspect_ratio_of_sphere(const Scene &s, const Value &v) {
  return s.shape_name == "sphere" && std::get<double>(v) != 0.0
             ? "must be 0 (or absent) for shape = \"sphere\""
             : "";
}

// Default fourier_kmax: the modes up to |k_a| ~ 1 D^-1 along the longest side, which cover the
// cubic fit's range (k1^2 <= 2, k3^2 <= 1 D^-2): 10 in the paper's 57 D box, 6 in a 28.5 D box.
// The cost grows as kmax^3, so a small box does not pay for modes no fit uses.
void fourier_kmax_from_box(Scene &s) {
  const Box &box = s.box;
  const double longest = std::max({box.length.x, box.length.y, box.length.z});
  s.fourier_kmax = !std::isfinite(longest) || !(longest > 0.0)
                       ? 10
                       : static_cast<int>(std::clamp(
                             1.0 + std::round(longest / (2.0 * std::numbers::pi)), 2.0, 64.0));
}

using enum Type;

// The public keys in canonical order, one entry each, the fields in the order of
// KeySpec. A default not given here is the initial value of the Scene member (scene.hpp).
// clang-format off
constexpr KeySpec kKeys[] = {
    // [system]
    {.section = "system", .name = "shape", .type = kChoice, .member = &Scene::shape_name,
     .limit = one_of(kShapes, "must be \"spherocylinder\" or \"sphere\""),
     .help = "\"spherocylinder\" or \"sphere\" (aspect_ratio 0)"},
    {.section = "system", .name = "aspect_ratio", .type = kReal, .member = &Scene::shape,
     .limit = non_negative(), .fallback = sphere_has_no_length, .relation = aspect_ratio_of_sphere,
     .default_text = "5 (0 for a sphere)", .help = "L/D, the cylinder length over the diameter"},
    {.section = "system", .name = "n", .type = kInteger, .member = &Scene::n,
     .limit = integers(1, kMaxBodies, "must be in [1, 10^12]"), .required = true,
     .help = "number of bodies"},
    {.section = "system", .name = "reduced_density", .type = kReal, .cross = true,
     .help = "rho / rho_cp in (0, 1) (or packing_fraction, or box)"},
    {.section = "system", .name = "packing_fraction", .type = kReal, .cross = true,
     .help = "n v0 / V, below close packing (or reduced_density, or box)"},
    {.section = "system", .name = "box", .type = kBox, .member = &Scene::box, .cross = true,
     .default_text = "from the density",
     .help = "sides in D: a number (a cube) or [lx, ly, lz] (or a density)"},
    // [init]
    {.section = "init", .name = "configuration", .type = kChoice, .member = &Scene::configuration,
     .limit = one_of(kConfigurations, "must be \"lattice\", \"isotropic\" or \"file\""),
     .help = "\"lattice\", \"isotropic\" (random axes compressed to the density) or \"file\""},
    {.section = "init", .name = "lattice", .type = kLattice, .member = &Scene::lattice,
     .cross = true, .when = lattice_start, .default_text = "\"auto\"",
     .help = "bodies per axis, product n; \"auto\" picks one that fits"},
    {.section = "init", .name = "file", .type = kString, .member = &Scene::init_file,
     .limit = non_empty("must name an H5MD or GSD file"), .required = true, .when = file_start,
     .help = "configuration = \"file\": an H5MD or .gsd (HOOMD) file; n and box must match"},
    {.section = "init", .name = "frame", .type = kInteger, .member = &Scene::init_frame,
     .when = file_start, .help = "configuration = \"file\": its frame; < 0 counts from the end"},
    {.section = "init", .name = "isotropic_sweeps", .type = kInteger,
     .member = &Scene::isotropic_sweeps, .limit = integers(1, 1000000000), .when = isotropic_start,
     .help = "configuration = \"isotropic\": Monte Carlo sweeps the compression may take"},
    {.section = "init", .name = "axis", .type = kChoice, .member = &Scene::axis,
     .limit = one_of(kAxisNames, "must be \"x\", \"y\" or \"z\""),
     .help = "the common body axis on the lattice"},
    {.section = "init", .name = "seed", .type = kInteger, .member = &Scene::seed,
     .limit = at_least(0), .help = "random seed of the velocities (and isotropic start)"},
    {.section = "init", .name = "temperature", .type = kReal, .member = &Scene::temperature,
     .limit = between(1e-6, 1e6),
     .help = "kT (hard bodies: T only sets the time scale, so far from 1 it is a mistake)"},
    // [run]
    {.section = "run", .name = "dt", .type = kReal, .member = &Scene::dt, .limit = positive(),
     .required = true, .help = "time step in tau"},
    {.section = "run", .name = "method", .type = kChoice, .member = &Scene::method,
     .limit = one_of(kMethods, "must be \"midpoint\" or \"exact\""),
     .help = "\"midpoint\" (the paper's: contacts resolved at the step's midpoint) or \"exact\" "
             "(collisions at their exact times within the step)"},
    {.section = "run", .name = "equilibration_steps", .type = kInteger,
     .member = &Scene::equilibration_steps, .limit = steps_limit(),
     .help = "steps before production (not averaged)"},
    {.section = "run", .name = "steps", .type = kInteger, .member = &Scene::steps,
     .limit = steps_limit(), .required = true, .relation = total_steps_fit,
     .help = "production steps"},
    {.section = "run", .name = "thermostat_interval", .type = kInteger,
     .member = &Scene::thermostat_interval, .limit = steps_limit(),
     .help = "steps between kinetic-energy rescalings; 0 = off"},
    {.section = "run", .name = "sample_interval", .type = kInteger,
     .member = &Scene::sample_interval, .limit = integers(1, kMaxSteps),
     .help = "steps per sample of S, P* and the kinetic energy"},
    {.section = "run", .name = "max_overlap", .type = kReal, .member = &Scene::max_overlap,
     .limit = between(0.0, 0.5), .help = "in D: a deeper overlap stops the run"},
    {.section = "run", .name = "solver_tolerance", .type = kReal,
     .member = &Scene::solver_tolerance, .limit = between(0.0, 1.0),
     .help = "relative tolerance of the multi-contact solver"},
    {.section = "run", .name = "solver_max_iterations", .type = kInteger,
     .member = &Scene::solver_max_iterations, .limit = at_least(1),
     .help = "iterations of the multi-contact solver"},
    {.section = "run", .name = "skin", .type = kReal, .member = &Scene::skin,
     .limit = between_closed(0.0, 2.0), .fallback = skin_for_method,
     .default_text = "0.3 (method = \"exact\": 1.0 for rods, 0.6 for spheres)",
     .help = "neighbour-list skin in D: speed only, never the trajectory"},
    // [output]
    {.section = "output", .name = "dir", .type = kString, .member = &Scene::output_dir,
     .limit = non_empty("must not be empty"), .help = "the run directory"},
    {.section = "output", .name = "log_interval", .type = kInteger, .member = &Scene::log_interval,
     .limit = steps_limit(), .help = "steps between plain progress lines; 0 = 20 per run"},
    {.section = "output", .name = "snapshot_interval", .type = kInteger,
     .member = &Scene::snapshot_interval, .limit = steps_limit(),
     .help = "steps between H5MD frames; 0 = the final state only"},
    {.section = "output", .name = "checkpoint_interval", .type = kInteger,
     .member = &Scene::checkpoint_interval, .limit = steps_limit(),
     .help = "steps between checkpoints; 0 = at the end and on a signal"},
    // [observables]
    {.section = "observables", .name = "frank", .type = kBoolean, .member = &Scene::frank,
     .help = "accumulate the Fourier order tensor (Frank constants)"},
    {.section = "observables", .name = "fourier_kmax", .type = kInteger,
     .member = &Scene::fourier_kmax, .limit = integers(2, 64), .fallback = fourier_kmax_from_box,
     .default_text = "1 + round(L / 2 pi), L the longest side",
     .help = "Fourier modes -kmax < k_a < kmax, k != 0"},
    {.section = "observables", .name = "fourier_interval", .type = kInteger,
     .member = &Scene::fourier_interval, .limit = steps_limit(),
     .help = "steps between Fourier samples; 0 = sample_interval"},
};
// clang-format on

// The value read for a key of this type, or nullopt after a report.
std::optional<Value> fetch(Reader &in, const KeySpec &spec) {
  const auto get = [&](auto value) -> std::optional<Value> {
    if (!in.get(spec.section, spec.name, value, spec.required)) return std::nullopt;
    return Value(std::move(value));
  };
  switch (spec.type) {
    case kInteger:
      return get(0LL);
    case kReal:
      return get(0.0);
    case kString:
    case kChoice:
      return get(std::string());
    case kBoolean:
      return get(false);
    default:
      return std::nullopt;  // kBox and kLattice are cross keys
  }
}

// The problem with a value outside the key's own limits, or empty.
std::string violation(const Limit &limit, const Value &value) {
  using enum Limit::Kind;
  const auto *real = std::get_if<double>(&value);
  const auto *text = std::get_if<std::string>(&value);
  switch (limit.kind) {
    case kIntegers: {
      const long long v = std::get<long long>(value);
      if (v < limit.min)
        return limit.why.empty() ? "must be >= " + std::to_string(limit.min)
                                 : std::string(limit.why);
      if (v > limit.max)
        return limit.why.empty() ? "must be at most " + std::to_string(limit.max)
                                 : std::string(limit.why);
      return {};
    }
    case kPositive:
      return std::isfinite(*real) && *real > 0.0 ? "" : "must be > 0 and finite";
    case kNonNegative:
      return std::isfinite(*real) && *real >= 0.0 ? "" : "must be >= 0 and finite";
    case kOpen:
    case kOpenClosed: {  // NaN never passes
      const bool closed = limit.kind == kOpenClosed;
      if (*real > limit.low && (closed ? *real <= limit.high : *real < limit.high)) return {};
      return "must be in (" + format_short(limit.low) + ", " + format_short(limit.high) +
             (closed ? "]" : ")");
    }
    case kNonEmpty:
      return text->empty() ? std::string(limit.why) : "";
    case kOneOf:
      return std::ranges::find(limit.choices, *text) == limit.choices.end() ? std::string(limit.why)
                                                                            : "";
    case kNone:
      break;
  }
  return {};
}

std::size_t choice_index(const KeySpec &spec, const std::string &name) {
  return static_cast<std::size_t>(std::ranges::find(spec.limit.choices, name) -
                                  spec.limit.choices.begin());
}

void store(const KeySpec &spec, Value value, Scene &scene) {
  std::visit(
      [&](auto member) {
        using M = decltype(member);
        if constexpr (std::is_same_v<M, long long Scene::*> || std::is_same_v<M, int Scene::*> ||
                      std::is_same_v<M, unsigned long long Scene::*>) {
          using T = std::remove_reference_t<decltype(scene.*member)>;
          scene.*member = spec.type == kChoice
                              ? static_cast<T>(choice_index(spec, std::get<std::string>(value)))
                              : static_cast<T>(std::get<long long>(value));
        } else if constexpr (std::is_same_v<M, Configuration Scene::*>) {
          scene.*member =
              static_cast<Configuration>(choice_index(spec, std::get<std::string>(value)));
        } else if constexpr (std::is_same_v<M, double Scene::*>) {
          scene.*member = std::get<double>(value);
        } else if constexpr (std::is_same_v<M, bool Scene::*>) {
          scene.*member = std::get<bool>(value);
        } else if constexpr (std::is_same_v<M, std::string Scene::*>) {
          scene.*member = std::move(std::get<std::string>(value));
        } else if constexpr (std::is_same_v<M, Shape Scene::*>) {  // the aspect ratio
          (scene.*member).length = std::get<double>(value) * (scene.*member).diameter;
        }
      },
      spec.member);
}

// "[a, b, c]" (appended piecewise: GCC 12 warns falsely on "[" + std::string).
std::string bracketed(const std::string &a, const std::string &b, const std::string &c) {
  std::string out = "[";
  for (const std::string *item : {&a, &b, &c}) {
    if (item != &a) out += ", ";
    out += *item;
  }
  return out + "]";
}

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

}  // namespace

std::span<const KeySpec> scene_keys() { return kKeys; }
std::span<const std::string_view> scene_sections() { return kSections; }

const KeySpec *find_key(std::string_view full) {
  for (const KeySpec &spec : kKeys)
    if (full_key(spec.section, spec.name) == full) return &spec;
  return nullptr;
}

bool is_string_key(const KeySpec &spec) { return spec.type == kString || spec.type == kChoice; }

std::string unknown_key(std::string_view full) {
  const auto dot = full.find('.');
  if (dot == std::string_view::npos)
    for (const std::string_view section : kSections)
      if (section == full) {  // a section alone, as in --set run=1: its keys, not a look-alike
        std::vector<std::string> keys;
        for (const KeySpec &spec : kKeys)
          if (spec.section == section) keys.push_back(full_key(section, spec.name));
        return fmt::format("'{}' is a section, not a key: name one of its keys ({})", full,
                           fmt::join(keys, ", "));
      }
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

void read_key(Reader &in, const KeySpec &spec, Scene &scene) {
  if (spec.when && !spec.when(scene)) return;
  if (!in.find(spec.section, spec.name) && !spec.required) {
    if (spec.fallback) spec.fallback(scene);
    return;
  }
  std::optional<Value> value = fetch(in, spec);
  if (!value) return;
  const std::string problem = violation(spec.limit, *value);
  if (!in.check(spec.section, spec.name, problem.empty(), problem)) return;
  if (spec.relation) {
    const std::string_view related = spec.relation(scene, *value);
    if (!in.check(spec.section, spec.name, related.empty(), related)) return;
  }
  store(spec, std::move(*value), scene);
}

std::string value_text(const KeySpec &spec, const Scene &scene) {
  return std::visit(
      [&](auto member) -> std::string {
        using M = decltype(member);
        if constexpr (std::is_same_v<M, std::monostate>) {
          return {};
        } else if constexpr (std::is_same_v<M, Configuration Scene::*> ||
                             std::is_same_v<M, int Scene::*>) {
          const auto v = static_cast<long long>(scene.*member);
          if (spec.type != kChoice) return std::to_string(v);
          const auto last = static_cast<long long>(spec.limit.choices.size()) - 1;
          return quote(spec.limit.choices[static_cast<std::size_t>(std::clamp(v, 0LL, last))]);
        } else if constexpr (std::is_same_v<M, long long Scene::*> ||
                             std::is_same_v<M, unsigned long long Scene::*>) {
          return std::to_string(scene.*member);
        } else if constexpr (std::is_same_v<M, double Scene::*>) {
          return format_real(scene.*member);
        } else if constexpr (std::is_same_v<M, bool Scene::*>) {
          return scene.*member ? "true" : "false";
        } else if constexpr (std::is_same_v<M, std::string Scene::*>) {
          return quote(scene.*member);
        } else if constexpr (std::is_same_v<M, Shape Scene::*>) {
          return format_real((scene.*member).length / (scene.*member).diameter);
        } else if constexpr (std::is_same_v<M, Box Scene::*>) {
          const Vec3 &l = (scene.*member).length;
          return bracketed(format_real(l.x), format_real(l.y), format_real(l.z));
        } else {
          const auto &counts = scene.*member;
          return bracketed(std::to_string(counts[0]), std::to_string(counts[1]),
                           std::to_string(counts[2]));
        }
      },
      spec.member);
}

}  // namespace hardrod::scene_detail

namespace hardrod {

// Every key that applies, section by section in table order; the densities are written as
// the box they gave, and the lattice as counts ("auto" resolved).
std::string scene_to_toml(const Scene &scene) {
  using namespace scene_detail;
  std::string out =
      "# hardrod scene, canonical form: every value resolved, box and lattice explicit\n";
  for (const std::string_view section : scene_sections()) {
    if (section != scene_sections().front()) out += "\n";
    out += "[";
    out += section;
    out += "]\n";
    for (const KeySpec &spec : scene_keys()) {
      if (spec.section != section || (spec.when && !spec.when(scene))) continue;
      if (std::holds_alternative<std::monostate>(spec.member)) continue;
      out += std::string(spec.name) + " = " + value_text(spec, scene) + "\n";
    }
  }
  return out;
}

std::string scene_keys_reference() {
  using namespace scene_detail;
  const Scene defaults;
  std::string out;
  for (const KeySpec &spec : scene_keys()) {
    std::string fallback = spec.required ? "required" : std::string(spec.default_text);
    if (fallback.empty() && !std::holds_alternative<std::monostate>(spec.member))
      fallback = value_text(spec, defaults);
    out += full_key(spec.section, spec.name) + " (" +
           std::string(kTypeNames[static_cast<int>(spec.type)]) +
           (fallback.empty() ? "" : "; " + fallback) + "): " + std::string(spec.help) + "\n";
  }
  return out;
}

}  // namespace hardrod
