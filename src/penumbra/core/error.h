// Errors that carry context: each layer that catches one may prepend where it happened
// ("scene.json: volumes[0].file: ..."), so the user reads the file, the key, the value and what was expected.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace penumbra {

class Error : public std::runtime_error {
public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  // A new error whose message is "context: original message".
  Error with_context(const std::string& context) const { return Error(context + ": " + what()); }
};

// A number as a user wrote it (shortest form: 0.5, 1e+06), for messages.
inline std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Runs f(); an Error escaping it gets `context` prepended.
template <class F>
auto with_context(const std::string& context, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    throw e.with_context(context);
  }
}

}  // namespace penumbra
