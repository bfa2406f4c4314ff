// Strict reading of one JSON object of the scene file: every key read is remembered, and finish()
// rejects the keys nobody asked for, naming their dotted path. Type and range errors name the path,
// the value and what was expected.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <string_view>

#include "penumbra/core/color.h"
#include "penumbra/core/error.h"
#include "penumbra/core/math.h"

namespace penumbra {

class JsonReader {
public:
  JsonReader(const nlohmann::json& object, std::string path);

  const std::string& path() const { return path_; }
  std::string key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  bool has(const std::string& key) const;          // present and not null
  const nlohmann::json& raw(const std::string& key);  // marks the key used; throws if absent

  std::string string(const std::string& key, const std::string& fallback);
  std::string required_string(const std::string& key);
  bool boolean(const std::string& key, bool fallback);
  float number(const std::string& key, float fallback, float lo = -kInfinity, float hi = kInfinity);
  std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi);
  Vec3 vec3(const std::string& key, const Vec3& fallback);
  Rgb color(const std::string& key, const Rgb& fallback);  // components in [0, 1]

  // Throws for every key of the object that was not read: "<path>.<key>: unknown key (expected one of ...)".
  void finish() const;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

private:
  const nlohmann::json& object_;
  std::string path_;
  mutable std::set<std::string> used_;
};

// The defaults a scene read took: every key a JsonReader looked for and did not find, by its dotted
// path, with the fallback it used (null where the reader computes it, e.g. from the data). What
// Engine::get answers for keys the document leaves out, so that a default is told from a typo.
using ReadDefaults = std::map<std::string, nlohmann::json>;

// While alive, the JsonReaders of this thread note their defaults into `defaults` (nested scopes: the
// innermost wins; null: none noted).
class RecordDefaults {
public:
  explicit RecordDefaults(ReadDefaults* defaults);
  ~RecordDefaults();
  RecordDefaults(const RecordDefaults&) = delete;
  RecordDefaults& operator=(const RecordDefaults&) = delete;

private:
  ReadDefaults* previous_;
};

// Notes a default taken outside JsonReader (a technique's declared parameter) into the current scope.
void note_default(const std::string& path, const nlohmann::json& value);

std::string json_brief(const nlohmann::json& value);  // the value as compact JSON, shortened for messages

// Parses JSON text. A syntax error, invalid UTF-8 or a number beyond the double range (2e308) throws
// Error "<what>: line L, column C: at <dotted.key.path>: <what went wrong>".
nlohmann::json parse_json_text(const std::string& text, const std::string& what);

// Throws Error "<what>: not valid UTF-8 (byte N)" unless s is valid UTF-8 (what nlohmann::json can hold
// and print).
void check_utf8(std::string_view s, const std::string& what);

// The value of `--set key=value`: JSON when it parses as JSON, else the text as a string. Error (with
// `what` in front) for text that is not UTF-8 and for a number beyond the double range (2e308), which
// would otherwise become the string "2e308".
nlohmann::json override_value(const std::string& value, const std::string& what);

}  // namespace penumbra
