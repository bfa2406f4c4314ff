// The values a scene gives the keys of its shadow and ambient techniques (`shadows.*` and `ambient.*`
// other than `technique` and the kinds), by key, as the scene-file reader checked them against the
// declarations of the techniques that read them (lighting/technique_info.h). A key the scene does not
// give is absent here: the technique takes the default its declaration names (ParamSpec::integer,
// number, choice). Integers are int64, numbers double, choices strings.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <variant>

namespace penumbra {

using ParamValue = std::variant<std::int64_t, double, std::string>;

class TechniqueParams {
public:
  void set(const std::string& key, std::int64_t value) { values_[key] = value; }
  void set(const std::string& key, int value) { values_[key] = static_cast<std::int64_t>(value); }
  void set(const std::string& key, double value) { values_[key] = value; }
  void set(const std::string& key, std::string value) { values_[key] = std::move(value); }
  void set(const std::string& key, const char* value) { values_[key] = std::string(value); }
  void set(const std::string& key, ParamValue value) { values_[key] = std::move(value); }
  void erase(const std::string& key) { values_.erase(key); }
  // The value the scene gave, or nullptr.
  const ParamValue* find(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() ? nullptr : &it->second;
  }
  const std::map<std::string, ParamValue, std::less<>>& values() const { return values_; }
  bool operator==(const TechniqueParams&) const = default;

private:
  std::map<std::string, ParamValue, std::less<>> values_;
};

}  // namespace penumbra
