#include "penumbra/scene_io/json_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace penumbra {

std::string json_brief(const nlohmann::json& value) {
  // Invalid UTF-8 in a string (only --set could put it there) is shown as U+FFFD rather than thrown.
  std::string s = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

namespace {

// nlohmann's "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ..." without
// the bracketed id.
std::string json_message(const char* what) {
  std::string m = what;
  if (!m.empty() && m[0] == '[') {
    const std::size_t end = m.find("] ");
    if (end != std::string::npos) m = m.substr(end + 2);
  }
  return m;
}

// Walks the text as the parser does and remembers the dotted key path of the value being read when the
// parser gives up, so that an error names the key ("lights.0.intensity") rather than a byte offset.
class PathSax : public nlohmann::json_sax<nlohmann::json> {
public:
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return push(false); }
  bool key(string_t& k) override {
    stack_.back().key = k;
    stack_.back().has_key = true;
    return true;
  }
  bool end_object() override { return pop(); }
  bool start_array(std::size_t) override { return push(true); }
  bool end_array() override { return pop(); }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) override {
    position_ = position;
    message_ = json_message(e.what());
    for (const Frame& f : stack_) {
      if (!f.array && !f.has_key) break;
      path_ += (path_.empty() ? "" : ".") + (f.array ? std::to_string(f.index) : f.key);
    }
    return false;
  }
  std::size_t position() const { return position_; }
  const std::string& message() const { return message_; }
  const std::string& path() const { return path_; }

private:
  struct Frame {
    bool array = false, has_key = false;
    std::size_t index = 0;
    std::string key;
  };
  bool value() {
    if (!stack_.empty() && stack_.back().array) ++stack_.back().index;
    return true;
  }
  bool push(bool array) {
    stack_.push_back({array, false, 0, {}});
    return true;
  }
  bool pop() {
    stack_.pop_back();
    return value();
  }
  std::vector<Frame> stack_;
  std::size_t position_ = 0;
  std::string message_, path_;
};

}  // namespace

nlohmann::json parse_json_text(const std::string& text, const std::string& what) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    // Parse again, only to say where: a syntax error, invalid UTF-8 or a number that overflows a double.
  }
  PathSax sax;
  nlohmann::json::sax_parse(text, &sax);
  const std::size_t end = std::min(sax.position(), text.size());
  std::size_t line = 1, line_start = 0;
  for (std::size_t i = 0; i < end; ++i)
    if (text[i] == '\n') ++line, line_start = i + 1;
  std::string message = sax.message();
  if (message.rfind("parse error at line", 0) == 0) message = message.substr(message.find(": ") + 2);  // said below
  throw Error(what + ": line " + std::to_string(line) + ", column " + std::to_string(end - line_start + 1) +
              (sax.path().empty() ? std::string() : ": at " + sax.path()) + ": " +
              (message.empty() ? "not valid JSON" : message) +
              (message.find("number overflow") != std::string::npos ? " (beyond the double range, ±1.8e308)" : ""));
}

void check_utf8(std::string_view s, const std::string& what) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte (RFC 3629)
    if (c < 0x80) n = 0;
    else if (c >= 0xC2 && c <= 0xDF) n = 1;
    else if (c == 0xE0) n = 2, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) n = 2;
    else if (c == 0xED) n = 2, hi = 0x9F;
    else if (c >= 0xEE && c <= 0xEF) n = 2;
    else if (c == 0xF0) n = 3, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) n = 3;
    else if (c == 0xF4) n = 3, hi = 0x8F;
    else throw Error(what + ": not valid UTF-8 (byte " + std::to_string(i + 1) + ")");
    for (std::size_t k = 1; k <= n; ++k) {
      const auto b = i + k < s.size() ? static_cast<unsigned char>(s[i + k]) : 0u;
      if (b < (k == 1 ? lo : 0x80u) || b > (k == 1 ? hi : 0xBFu))
        throw Error(what + ": not valid UTF-8 (byte " + std::to_string(i + k + 1) + ")");
    }
    i += n + 1;
  }
}

namespace {

thread_local ReadDefaults* current_defaults = nullptr;

// A float default as the shortest decimal that reads back as the same float (0.55f is 0.55, not
// 0.550000011920929).
nlohmann::json float_json(float v) {
  char text[32];
  for (int digits = 6; digits <= 9; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, static_cast<double>(v));
    if (std::strtof(text, nullptr) == v) break;
  }
  return std::strtod(text, nullptr);
}

}  // namespace

RecordDefaults::RecordDefaults(ReadDefaults* defaults) : previous_(current_defaults) { current_defaults = defaults; }
RecordDefaults::~RecordDefaults() { current_defaults = previous_; }

void note_default(const std::string& path, const nlohmann::json& value) {
  if (!current_defaults) return;
  auto& slot = (*current_defaults)[path];
  if (slot.is_null()) slot = value;
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
  const bool present = it != object_.end() && !it->is_null();
  if (!present) note_default(key_path(key), nullptr);  // known; its fallback (if any) is noted by the caller
  return present;
}

const nlohmann::json& JsonReader::raw(const std::string& key) {
  used_.insert(key);
  auto it = object_.find(key);
  if (it == object_.end()) fail(key, "missing");
  return *it;
}

std::string JsonReader::string(const std::string& key, const std::string& fallback) {
  if (!has(key)) return note_default(key_path(key), fallback), fallback;
  const auto& v = raw(key);
  if (!v.is_string()) fail(key, "expected a string, got " + json_brief(v));
  return v.get<std::string>();
}

std::string JsonReader::required_string(const std::string& key) {
  if (!has(key)) fail(key, "missing (expected a string)");
  return string(key, "");
}

bool JsonReader::boolean(const std::string& key, bool fallback) {
  if (!has(key)) return note_default(key_path(key), fallback), fallback;
  const auto& v = raw(key);
  if (!v.is_boolean()) fail(key, "expected true or false, got " + json_brief(v));
  return v.get<bool>();
}

float JsonReader::number(const std::string& key, float fallback, float lo, float hi) {
  if (!has(key)) return note_default(key_path(key), float_json(fallback)), fallback;
  const auto& v = raw(key);
  if (!v.is_number()) fail(key, "expected a number, got " + json_brief(v));
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || d > hi)
    fail(key, "value " + json_brief(v) + " is out of range (expected " + std::to_string(lo) + " .. " + std::to_string(hi) + ")");
  return static_cast<float>(d);
}

std::int64_t JsonReader::integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi) {
  if (!has(key)) return note_default(key_path(key), fallback), fallback;
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
  if (!has(key)) return note_default(key_path(key), {float_json(fallback.x), float_json(fallback.y), float_json(fallback.z)}), fallback;
  const auto& v = raw(key);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    fail(key, "expected an array of three numbers, got " + json_brief(v));
  Vec3 r{v[0].get<float>(), v[1].get<float>(), v[2].get<float>()};
  if (!is_finite(r)) fail(key, "expected finite numbers, got " + json_brief(v));
  return r;
}

Rgb JsonReader::color(const std::string& key, const Rgb& fallback) {
  if (!has(key)) return note_default(key_path(key), {float_json(fallback[0]), float_json(fallback[1]), float_json(fallback[2])}), fallback;
  const Vec3 c = vec3(key, {});
  for (int i = 0; i < 3; ++i)
    if (c[i] < 0 || c[i] > 1)
      fail(key, "colour components must be in [0, 1] (linear RGB), got " + json_brief(raw(key)) +
                    (c[i] > 1 && c[i] <= 255 ? "; an 8-bit colour is its bytes / 255, made linear" : ""));
  return {c.x, c.y, c.z};
}

void JsonReader::finish() const {
  std::string known;
  for (const auto& k : used_) known += (known.empty() ? "" : ", ") + k;
  for (auto it = object_.begin(); it != object_.end(); ++it)
    if (!used_.count(it.key())) fail(it.key(), "unknown key (expected one of: " + known + ")");
}

}  // namespace penumbra

namespace penumbra {

nlohmann::json override_value(const std::string& value, const std::string& what) {
  check_utf8(value, what + ": the value");
  nlohmann::json parsed = nlohmann::json::parse(value, nullptr, /*allow_exceptions=*/false);
  if (!parsed.is_discarded()) return parsed;
  const std::string_view v = value;
  if (!v.empty() && (std::isdigit(static_cast<unsigned char>(v[0])) || v[0] == '-') &&
      v.find_first_not_of("0123456789+-.eE") == std::string_view::npos && !std::isfinite(std::strtod(value.c_str(), nullptr)))
    throw Error(what + ": the number " + value + " is beyond the double range (±1.8e308)");
  return value;
}

}  // namespace penumbra
