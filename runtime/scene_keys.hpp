// The scene keys as one table: for every public key its section and name, type, where it
// goes in Scene, its own limits, its default and a line of help. The table drives reading a
// key (read_key), `--set` overrides (a string key's value is taken literally), the "did you
// mean" suggestions for unknown keys, and the canonical writer (scene_to_toml), so a key is
// spelled once. Rules that tie keys together (one density key, the box from the density, the
// lattice that must fit) are not here: runtime/scene.cpp applies them after a section's keys.
// Internal to the scene reader; the public interface is runtime/scene.hpp.
#pragma once

#include <array>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "runtime/scene.hpp"
#include "runtime/scene_text.hpp"

namespace hardrod::scene_detail {

enum class Type {
  kInteger,  // an integer, or a float with an integral value
  kReal,     // an integer or a float
  kString,
  kChoice,  // one of a few strings
  kBoolean,
  kBox,      // a number (a cube) or three numbers
  kLattice,  // "auto" or three integers
};

// A key's own limits, and the problem reported when a value is outside them.
struct Limit {
  enum class Kind {
    kNone,
    kIntegers,     // [min, max]: "must be >= min", "must be at most max" unless `why`
    kPositive,     // finite and > 0: "must be > 0 and finite"
    kNonNegative,  // finite and >= 0: "must be >= 0 and finite"
    kOpen,         // (low, high): "must be in (low, high)"
    kOpenClosed,   // (low, high]: "must be in (low, high]"
    kNonEmpty,     // a non-empty string: `why`
    kOneOf,        // one of `choices` (in the order of the member's enum): `why`
  };
  Kind kind = Kind::kNone;
  long long min = 0, max = std::numeric_limits<long long>::max();
  double low = 0.0, high = 0.0;
  std::string_view why = {};
  std::span<const std::string_view> choices = {};
};

// Where a key's value goes in Scene. A kChoice key into an int or enum member stores the
// index of its choice. monostate: the key is resolved into other members (the densities
// into the box) and is not written back.
using Member =
    std::variant<std::monostate, long long Scene::*, int Scene::*, unsigned long long Scene::*,
                 double Scene::*, bool Scene::*, std::string Scene::*, Configuration Scene::*,
                 Shape Scene::*, Box Scene::*, std::array<long long, 3> Scene::*>;

// A value as read, before it is stored.
using Value = std::variant<long long, double, bool, std::string>;

struct KeySpec {
  std::string_view section = {};
  std::string_view name = {};
  Type type = Type::kInteger;
  Member member = {};
  Limit limit = {};
  bool required = false;
  // Read by the cross-key rules in scene.cpp, not by read_key: its meaning depends on other
  // keys (the densities and box, the lattice).
  bool cross = false;
  // Read and written only when this holds for the keys before it (nullptr: always).
  bool (*when)(const Scene &) = nullptr;
  // The default when the key is absent, from the keys before it (nullptr: the member's
  // initial value in Scene).
  void (*fallback)(Scene &) = nullptr;
  // A limit against the keys before it: the problem, or empty when the value is fine.
  std::string_view (*relation)(const Scene &, const Value &) = nullptr;
  std::string_view default_text = {};  // the default, for the reference
  std::string_view help = {};
};

// Every key, in canonical order: sections in the order of scene_sections(), and within a
// section the order they are read in and written in.
std::span<const KeySpec> scene_keys();
std::span<const std::string_view> scene_sections();
const KeySpec *find_key(std::string_view full);
bool is_string_key(const KeySpec &spec);  // an override value for it is taken literally

// "unknown key 'run.dtt' (did you mean 'run.dt'?)"; a bare name is matched by key name.
std::string unknown_key(std::string_view full);
// "unknown section '[outptu]' (did you mean '[output]'?)"
std::string unknown_section(std::string_view name);

// Reads one key that is not `cross`: its type, limits, relation; stores it in `scene`, or
// applies its fallback when it is absent. Every problem is reported through `in`.
void read_key(Reader &in, const KeySpec &spec, Scene &scene);

// The key's value in `scene` as canonical TOML text (monostate members have none).
std::string value_text(const KeySpec &spec, const Scene &scene);

}  // namespace hardrod::scene_detail
