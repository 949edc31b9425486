// Scene values as text and typed access to a parsed scene: the formatting shared by the
// reader's messages and the canonical writer, and a Reader that fetches a key as an integer,
// number, string or boolean and records every problem it meets, each naming the full key and
// the offending value as the user wrote it. Knows no key names (runtime/scene_keys.hpp does)
// and no cross-key rules (runtime/scene.cpp). Internal to the scene reader.
#pragma once

#include <toml++/toml.h>

#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace hardrod::scene_detail {

std::string full_key(std::string_view section, std::string_view name);
std::string join(const std::vector<std::string> &parts, std::string_view separator);
std::string trim(std::string_view s);

// Shortest text that reads back to the same double, always recognisable as a TOML float.
std::string format_real(double v);
// For derived numbers in messages (spacings, sides): readable rather than exact.
std::string format_short(double v);
// A TOML basic string: quotes, backslashes and control characters escaped.
std::string quote(std::string_view s);
// The offending value as the user wrote it, cut short if it is long junk.
std::string describe(const toml::node &node);

// An integer, or a float with an integral value (1e8 is a fine step count).
std::optional<long long> as_integer(const toml::node &node);
// An integer or a float.
std::optional<double> as_real(const toml::node &node);
std::optional<std::string> as_string(const toml::node &node);
std::optional<bool> as_boolean(const toml::node &node);

// Typed access to the parsed table that records every problem it meets. Each get leaves
// `out` at its default when the key is absent and returns false only after a report. A key
// with a reported problem is not sound, so checks that build on it can stand aside.
class Reader {
 public:
  Reader(const toml::table &root, std::vector<std::string> &problems)
      : root_(root), problems_(problems) {}

  const toml::node *find(std::string_view section, std::string_view name) const;

  bool get(std::string_view section, std::string_view name, long long &out, bool required = false);
  bool get(std::string_view section, std::string_view name, double &out, bool required = false);
  bool get(std::string_view section, std::string_view name, std::string &out,
           bool required = false);
  bool get(std::string_view section, std::string_view name, bool &out, bool required = false);

  // Reports "section.key = value: why" unless `holds`.
  bool check(std::string_view section, std::string_view name, bool holds, std::string_view why);
  void report(std::string_view section, std::string_view name, std::string_view why);
  // A problem that names its keys itself.
  void add(std::string problem) { problems_.push_back(std::move(problem)); }
  // No problem has been reported for this key (absent keys are sound unless required).
  bool sound(std::string_view section, std::string_view name) const;

 private:
  template <class T, class Convert>
  bool fetch(std::string_view section, std::string_view name, T &out, bool required,
             Convert convert, std::string_view expected);

  const toml::table &root_;
  std::vector<std::string> &problems_;
  std::set<std::string, std::less<>> unsound_;
};

}  // namespace hardrod::scene_detail
