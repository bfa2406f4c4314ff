// The viewer's request and message checks that stand between the network and the engine
// (docs/viewer.md, "Security"): which Host and Origin headers a request may carry, the rules for the
// token, the size limits of edits, and how names and paths appear in error replies. Pure functions,
// so that each rule reads on its own and the server only calls them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace penumbra::viewer_security {

// A token shorter than this is refused: guessing 16 of [A-Za-z0-9_-] takes 64^16 tries.
constexpr std::size_t kMinTokenLength = 16;

// Error naming the rule the token breaks (too short, a character other than letters, digits, '-', '_').
void check_token(const std::string& token);

// Where the server listens, and which other origins the operator admitted (--allow-origin).
struct Listener {
  std::string host;  // the bound address as given: "127.0.0.1", "0.0.0.0", "::1", ...
  std::uint16_t port = 0;
  std::vector<std::string> allowed_origins;  // "http://name:port", normalised by check_origin_option
};

// Error unless `origin` is scheme://host[:port] with nothing after it; returns it lower-cased.
std::string checked_origin_option(const std::string& origin);
// Error unless `source` is a CSP frame-ancestors source of the form http(s)://HOST[:PORT|:*] (no
// path, no separators that would end the policy); returns it lower-cased.
std::string checked_frame_ancestor(const std::string& source);

// A Host header names this server: an IP literal or "localhost" with our port (a name an attacker's
// DNS can point at us, DNS rebinding, is neither), the machine's own name when bound to all
// interfaces, or the host of an allowed origin.
bool host_allowed(std::string_view host_header, const Listener& listener);

// A WebSocket upgrade's Origin: absent (not a browser), the page's own (http://HOST as the Host header
// says), or an allowed origin. Any other site's page is refused (cross-site WebSocket hijacking).
bool origin_allowed(std::string_view origin, std::string_view host_header, const Listener& listener);

// Refuses an edit whose value at a limited key lies outside its range, with an Error naming the key,
// the value and the limit. `path` is the edit's path and `value` its value (an object is walked, so
// {"camera": {"width": 16384}} is refused like {"camera.width": 16384}).
void check_edit_limits(const std::string& path, const nlohmann::json& value);

// Refuses an edit whose path or any string in its value holds a control character (a NUL cuts a C
// string short, so the error would name something else than what was sent).
void check_no_control_characters(const std::string& path, const nlohmann::json& value);

// `text` as a JSON string literal: quotes, control characters and bytes that are not UTF-8 escaped.
std::string json_quoted(std::string_view text);

// `message` with the data root's absolute spelling (as given and canonical) replaced by "<data root>",
// so that a reply never tells a client where on the machine the data lies.
std::string without_root(std::string message, const std::filesystem::path& data_root);

}  // namespace penumbra::viewer_security
