// Scene values as text and the problem-recording Reader (see scene_text.hpp).
#include "runtime/scene_text.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace hardrod::scene_detail {

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

std::string format_real(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  std::string text(buffer, result.ptr);
  if (std::isfinite(v) && text.find_first_of(".e") == std::string::npos) text += ".0";
  return text;
}

std::string format_short(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

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

std::string describe(const toml::node &node) {
  std::string text;
  if (const auto *array = node.as_array()) {
    text.push_back('[');
    for (const toml::node &item : *array) {
      if (text.size() > 1) text.append(", ");
      text.append(describe(item));
    }
    text.push_back(']');
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

std::optional<long long> as_integer(const toml::node &node) {
  if (const auto *integer = node.as_integer()) return integer->get();
  if (const auto *real = node.as_floating_point()) {
    const double v = real->get();
    if (std::isfinite(v) && v == std::trunc(v) && std::fabs(v) <= 0x1p53)
      return static_cast<long long>(v);
  }
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

std::optional<bool> as_boolean(const toml::node &node) {
  if (const auto *b = node.as_boolean()) return b->get();
  return std::nullopt;
}

// ---- Reader -----------------------------------------------------------------------------

const toml::node *Reader::find(std::string_view section, std::string_view name) const {
  const toml::table *table = root_.get_as<toml::table>(section);
  return table ? table->get(name) : nullptr;
}

template <class T, class Convert>
bool Reader::fetch(std::string_view section, std::string_view name, T &out, bool required,
                   Convert convert, std::string_view expected) {
  const toml::node *node = find(section, name);
  if (!node) {
    if (required) {
      unsound_.insert(full_key(section, name));
      add("missing required key '" + full_key(section, name) + "'");
    }
    return !required;
  }
  if (std::optional<T> value = convert(*node)) {
    out = std::move(*value);
    return true;
  }
  report(section, name, expected);
  return false;
}

bool Reader::get(std::string_view section, std::string_view name, long long &out, bool required) {
  return fetch(section, name, out, required, as_integer, "expected an integer");
}
bool Reader::get(std::string_view section, std::string_view name, double &out, bool required) {
  return fetch(section, name, out, required, as_real, "expected a number");
}
bool Reader::get(std::string_view section, std::string_view name, std::string &out, bool required) {
  return fetch(section, name, out, required, as_string, "expected a string");
}
bool Reader::get(std::string_view section, std::string_view name, bool &out, bool required) {
  return fetch(section, name, out, required, as_boolean, "expected true or false");
}

bool Reader::check(std::string_view section, std::string_view name, bool holds,
                   std::string_view why) {
  if (!holds) report(section, name, why);
  return holds;
}

void Reader::report(std::string_view section, std::string_view name, std::string_view why) {
  const toml::node *node = find(section, name);
  unsound_.insert(full_key(section, name));
  add(full_key(section, name) + " = " + (node ? describe(*node) : "(default)") + ": " +
      std::string(why));
}

bool Reader::sound(std::string_view section, std::string_view name) const {
  return !unsound_.contains(full_key(section, name));
}

}  // namespace hardrod::scene_detail
