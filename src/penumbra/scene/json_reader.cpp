#include "penumbra/scene/json_reader.h"

#include <cmath>

namespace penumbra {

std::string json_brief(const nlohmann::json& value) {
  std::string s = value.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

JsonReader::JsonReader(const nlohmann::json& object, std::string path) : object_(object), path_(std::move(path)) {
  if (!object_.is_object())
    throw Error((path_.empty() ? std::string("scene") : path_) + ": expected a JSON object, got " + json_brief(object_));
}

void JsonReader::fail(const std::string& key, const std::string& what) const {
  throw Error(key_path(key) + ": " + what);
}

bool JsonReader::has(const std::string& key) const {
  auto it = object_.find(key);
  used_.insert(key);
  return it != object_.end() && !it->is_null();
}

const nlohmann::json& JsonReader::raw(const std::string& key) {
  used_.insert(key);
  auto it = object_.find(key);
  if (it == object_.end()) fail(key, "missing");
  return *it;
}

std::string JsonReader::string(const std::string& key, const std::string& fallback) {
  if (!has(key)) return fallback;
  const auto& v = raw(key);
  if (!v.is_string()) fail(key, "expected a string, got " + json_brief(v));
  return v.get<std::string>();
}

std::string JsonReader::required_string(const std::string& key) {
  if (!has(key)) fail(key, "missing (expected a string)");
  return string(key, "");
}

bool JsonReader::boolean(const std::string& key, bool fallback) {
  if (!has(key)) return fallback;
  const auto& v = raw(key);
  if (!v.is_boolean()) fail(key, "expected true or false, got " + json_brief(v));
  return v.get<bool>();
}

float JsonReader::number(const std::string& key, float fallback, float lo, float hi) {
  if (!has(key)) return fallback;
  const auto& v = raw(key);
  if (!v.is_number()) fail(key, "expected a number, got " + json_brief(v));
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || d > hi)
    fail(key, "value " + json_brief(v) + " is out of range (expected " + std::to_string(lo) + " .. " + std::to_string(hi) + ")");
  return static_cast<float>(d);
}

std::int64_t JsonReader::integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi) {
  if (!has(key)) return fallback;
  const auto& v = raw(key);
  if (!v.is_number_integer() && !(v.is_number_float() && std::floor(v.get<double>()) == v.get<double>() &&
                                   std::abs(v.get<double>()) < 9e15))
    fail(key, "expected an integer, got " + json_brief(v));
  const std::int64_t i = v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)
                             ? INT64_MAX
                             : (v.is_number_float() ? static_cast<std::int64_t>(v.get<double>()) : v.get<std::int64_t>());
  if (i < lo || i > hi)
    fail(key, "value " + json_brief(v) + " is out of range (expected an integer " + std::to_string(lo) + " .. " + std::to_string(hi) + ")");
  return i;
}

Vec3 JsonReader::vec3(const std::string& key, const Vec3& fallback) {
  if (!has(key)) return fallback;
  const auto& v = raw(key);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    fail(key, "expected an array of three numbers, got " + json_brief(v));
  Vec3 r{v[0].get<float>(), v[1].get<float>(), v[2].get<float>()};
  if (!is_finite(r)) fail(key, "expected finite numbers, got " + json_brief(v));
  return r;
}

Rgb JsonReader::color(const std::string& key, const Rgb& fallback) {
  if (!has(key)) return fallback;
  const Vec3 c = vec3(key, {});
  for (int i = 0; i < 3; ++i)
    if (c[i] < 0 || c[i] > 1) fail(key, "colour components must be in [0, 1], got " + json_brief(raw(key)));
  return {c.x, c.y, c.z};
}

void JsonReader::finish() const {
  std::string known;
  for (const auto& k : used_) known += (known.empty() ? "" : ", ") + k;
  for (auto it = object_.begin(); it != object_.end(); ++it)
    if (!used_.count(it.key())) fail(it.key(), "unknown key (expected one of: " + known + ")");
}

}  // namespace penumbra
