#include "penumbra/lighting/technique_info.h"

#include <algorithm>
#include <cmath>
#include <charconv>
#include <cstdint>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

// A number as a scene file would write it: integral values whole (1000000, not 1e+06), others the
// shortest text that reads back exactly.
std::string number_text(double v) {
  char text[32];
  if (std::floor(v) == v && std::abs(v) < 1e16) return std::to_string(static_cast<std::int64_t>(v));
  return std::string(text, std::to_chars(text, text + sizeof text, v).ptr);
}

// "a, b or c"
std::string alternatives(const std::vector<std::string>& items) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i) s += (i == 0 ? "" : i + 1 == items.size() ? " or " : ", ") + items[i];
  return s;
}

}  // namespace

std::string to_string(TechniqueFamily family) { return family == TechniqueFamily::Shadow ? "shadows" : "ambient"; }

std::int64_t ParamSpec::integer(const TechniqueParams& params) const {
  if (const ParamValue* v = params.find(key)) {
    if (const auto* i = std::get_if<std::int64_t>(v)) return *i;
    if (const auto* d = std::get_if<double>(v)) return static_cast<std::int64_t>(*d);
    throw Error(key + ": expected an integer");
  }
  return static_cast<std::int64_t>(default_number);
}

double ParamSpec::number(const TechniqueParams& params) const {
  if (const ParamValue* v = params.find(key)) {
    if (const auto* d = std::get_if<double>(v)) return *d;
    if (const auto* i = std::get_if<std::int64_t>(v)) return static_cast<double>(*i);
    throw Error(key + ": expected a number");
  }
  return default_number;
}

const std::string& ParamSpec::choice(const TechniqueParams& params) const {
  if (const ParamValue* v = params.find(key)) {
    if (const auto* s = std::get_if<std::string>(v)) return *s;
    throw Error(key + ": expected one of " + alternatives(choices));
  }
  return default_choice;
}

std::string ParamSpec::check(const ParamValue& value) const {
  switch (type) {
    case ParamType::Choice: {
      const auto* s = std::get_if<std::string>(&value);
      if (s && std::find(choices.begin(), choices.end(), *s) != choices.end()) return {};
      return "expected " + alternatives(choices);
    }
    case ParamType::Integer:
      if (!std::holds_alternative<std::int64_t>(value)) return "expected an integer (" + allowed_text() + ")";
      break;
    case ParamType::Number:
      if (std::holds_alternative<std::string>(value)) return "expected a number (" + allowed_text() + ")";
      break;
  }
  const double v = std::holds_alternative<std::int64_t>(value) ? static_cast<double>(std::get<std::int64_t>(value)) : std::get<double>(value);
  if (std::find(also.begin(), also.end(), v) != also.end()) return {};
  if (!only.empty()) return std::find(only.begin(), only.end(), v) != only.end() ? std::string{} : "expected " + allowed_text();
  if (std::isfinite(v) && v >= min && v <= max) return {};
  return "out of range (expected " + allowed_text() + ")";
}

std::string ParamSpec::default_text() const {
  if (type == ParamType::Choice) return default_choice;
  return number_text(default_number);
}

std::string ParamSpec::allowed_text() const {
  if (type == ParamType::Choice) return alternatives(choices);
  std::vector<std::string> values;
  if (!only.empty()) {
    for (double v : only) values.push_back(number_text(v));
  } else {
    values.push_back(number_text(min) + " .. " + number_text(max));
  }
  for (double v : also) values.push_back(number_text(v));
  return alternatives(values);
}

std::string ParamSpec::type_text() const {
  switch (type) {
    case ParamType::Integer: return "integer";
    case ParamType::Number: return "number";
    case ParamType::Choice: return "choice";
  }
  return "?";
}

ParamSpec integer_param(std::string key, std::int64_t default_value, std::int64_t min, std::int64_t max, std::string unit,
                        std::string meaning, ParamRole role) {
  ParamSpec p;
  p.key = std::move(key);
  p.type = ParamType::Integer;
  p.default_number = static_cast<double>(default_value);
  p.min = static_cast<double>(min);
  p.max = static_cast<double>(max);
  p.unit = std::move(unit);
  p.meaning = std::move(meaning);
  p.role = role;
  return p;
}

ParamSpec number_param(std::string key, double default_value, double min, double max, std::string unit, std::string meaning,
                       ParamRole role) {
  ParamSpec p;
  p.key = std::move(key);
  p.type = ParamType::Number;
  p.default_number = default_value;
  p.min = min;
  p.max = max;
  p.unit = std::move(unit);
  p.meaning = std::move(meaning);
  p.role = role;
  return p;
}

ParamSpec choice_param(std::string key, std::string default_choice, std::vector<std::string> choices, std::string meaning) {
  ParamSpec p;
  p.key = std::move(key);
  p.type = ParamType::Choice;
  p.default_choice = std::move(default_choice);
  p.choices = std::move(choices);
  p.meaning = std::move(meaning);
  return p;
}

const ParamSpec* TechniqueInfo::param(std::string_view key) const {
  for (const ParamSpec& p : params)
    if (p.key == key) return &p;
  return nullptr;
}

}  // namespace penumbra
