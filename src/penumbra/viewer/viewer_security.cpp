#include "penumbra/viewer/viewer_security.h"

#include <boost/asio/ip/address.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <unistd.h>

#include "penumbra/core/error.h"

namespace penumbra::viewer_security {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// "name:port", "[v6]:port" or "name" split into name (brackets removed) and port ("" when absent).
std::pair<std::string, std::string> split_host_port(std::string_view authority) {
  if (!authority.empty() && authority.front() == '[') {
    const auto close = authority.find(']');
    if (close == std::string_view::npos) return {"", ""};
    const std::string_view rest = authority.substr(close + 1);
    return {std::string(authority.substr(1, close - 1)), rest.size() > 1 && rest[0] == ':' ? std::string(rest.substr(1)) : ""};
  }
  const auto colon = authority.rfind(':');
  if (colon == std::string_view::npos) return {std::string(authority), ""};
  return {std::string(authority.substr(0, colon)), std::string(authority.substr(colon + 1))};
}

bool is_ip_literal(const std::string& name) {
  boost::system::error_code ec;
  boost::asio::ip::make_address(name, ec);
  return !ec;
}

bool binds_all_interfaces(const std::string& host) {
  boost::system::error_code ec;
  const auto address = boost::asio::ip::make_address(host, ec);
  return !ec && address.is_unspecified();
}

std::string machine_name() {
  std::array<char, 256> name{};
  if (::gethostname(name.data(), name.size() - 1) != 0) return "";
  return lower(name.data());
}

// The authority (host:port) of an allowed origin "scheme://host:port".
std::string origin_authority(const std::string& origin) { return origin.substr(origin.find("://") + 3); }

// The server's limits on sizes the page also limits (js/view.js clamps the view to 16..4096 pixels): a
// client that skips the page must not get a 56-second, 2-GB frame by asking for 16384².
struct Limit {
  const char* path;
  std::int64_t min, max;
};
constexpr Limit kLimits[] = {
    {"camera.width", 16, 4096},
    {"camera.height", 16, 4096},
};

}  // namespace

void check_token(const std::string& token) {
  if (token.size() < kMinTokenLength)
    throw Error("token: " + std::to_string(token.size()) + " characters (expected at least " + std::to_string(kMinTokenLength) +
                "; leave it out for a random one)");
  for (char c : token)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_')
      throw Error("token: character " + json_quoted(std::string(1, c)) + " (expected letters, digits, '-' and '_' only)");
}

std::string checked_origin_option(const std::string& origin) {
  const std::string o = lower(origin);
  const auto scheme_end = o.find("://");
  const bool scheme_ok = scheme_end != std::string::npos && (o.compare(0, scheme_end, "http") == 0 || o.compare(0, scheme_end, "https") == 0);
  const std::string authority = scheme_ok ? o.substr(scheme_end + 3) : "";
  if (!scheme_ok || authority.empty() || authority.find_first_of("/?#@ ") != std::string::npos)
    throw Error("--allow-origin " + json_quoted(origin) + ": expected an origin, http(s)://HOST[:PORT] with no path (e.g. http://localhost:9000)");
  return o;
}

std::string checked_frame_ancestor(const std::string& source) {
  const std::string o = lower(source);
  const auto scheme_end = o.find("://");
  const bool scheme_ok = scheme_end != std::string::npos && (o.compare(0, scheme_end, "http") == 0 || o.compare(0, scheme_end, "https") == 0);
  const std::string authority = scheme_ok ? o.substr(scheme_end + 3) : "";
  const bool chars_ok = !authority.empty() && std::all_of(authority.begin(), authority.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' || c == '*' || c == '[' || c == ']';
  });
  if (!scheme_ok || !chars_ok)
    throw Error("frame ancestor " + json_quoted(source) + ": expected http(s)://HOST[:PORT] or http(s)://HOST:* (e.g. http://localhost:*)");
  return o;
}

bool host_allowed(std::string_view host_header, const Listener& listener) {
  const std::string authority = lower(host_header);
  for (const std::string& origin : listener.allowed_origins)
    if (authority == origin_authority(origin)) return true;
  const auto [name, port] = split_host_port(authority);
  if (name.empty() || port != std::to_string(listener.port)) return false;
  if (name == "localhost" || is_ip_literal(name)) return true;
  return binds_all_interfaces(listener.host) && name == machine_name();
}

bool origin_allowed(std::string_view origin, std::string_view host_header, const Listener& listener) {
  if (origin.empty()) return true;
  const std::string o = lower(origin);
  if (o == "http://" + lower(host_header)) return true;
  return std::find(listener.allowed_origins.begin(), listener.allowed_origins.end(), o) != listener.allowed_origins.end();
}

void check_edit_limits(const std::string& path, const nlohmann::json& value) {
  if (value.is_object()) {
    for (const auto& [key, v] : value.items()) check_edit_limits(path.empty() ? key : path + "." + key, v);
    return;
  }
  for (const Limit& limit : kLimits) {
    if (path != limit.path) continue;
    // a non-integer is left to the engine, whose error names the type it expects
    if (!value.is_number()) return;
    const double v = value.get<double>();
    if (v < static_cast<double>(limit.min) || v > static_cast<double>(limit.max))
      throw Error(path + ": " + value.dump() + " is outside " + std::to_string(limit.min) + ".." + std::to_string(limit.max) +
                  " (the viewer's limit)");
  }
}

void check_no_control_characters(const std::string& path, const nlohmann::json& value) {
  auto has_control = [](const std::string& s) {
    return std::any_of(s.begin(), s.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; });
  };
  if (has_control(path)) throw Error("edit path " + json_quoted(path) + ": control characters are not allowed in a path");
  if (value.is_string() && has_control(value.get<std::string>()))
    throw Error(path + ": " + json_quoted(value.get<std::string>()) + ": control characters are not allowed in a value");
  if (value.is_object())
    for (const auto& [key, v] : value.items()) check_no_control_characters(path + "." + key, v);
  if (value.is_array())
    for (std::size_t i = 0; i < value.size(); ++i) check_no_control_characters(path + "." + std::to_string(i), value[i]);
}

std::string json_quoted(std::string_view text) {
  return nlohmann::json(std::string(text)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string without_root(std::string message, const std::filesystem::path& data_root) {
  std::error_code ec;
  const std::filesystem::path canonical = std::filesystem::weakly_canonical(data_root, ec);
  for (const std::string& root : {data_root.string(), ec ? std::string() : canonical.string()}) {
    if (root.empty() || root == "/") continue;
    for (const std::string& spelling : {root + "/", root}) {
      // a name inside the root is shown relative to it; the root itself as "<data root>"
      const std::string replacement = spelling.back() == '/' ? "" : "<data root>";
      for (auto at = message.find(spelling); at != std::string::npos; at = message.find(spelling, at + replacement.size()))
        message.replace(at, spelling.size(), replacement);
    }
  }
  return message;
}

}  // namespace penumbra::viewer_security
