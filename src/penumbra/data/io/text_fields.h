// Text helpers shared by the file readers (NRRD headers, PDB/mmCIF checks, .gro, .xyz): lines with
// their numbers, blank-separated fields, whole-token numbers, and text made safe for messages.
#pragma once

#include <cctype>
#include <charconv>
#include <cstddef>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace penumbra::io_detail {

constexpr std::string_view kBlanks = " \t\r\n\v\f";

inline std::string_view trim(std::string_view s) {
  const std::size_t b = s.find_first_not_of(kBlanks);
  if (b == std::string_view::npos) return {};
  return s.substr(b, s.find_last_not_of(kBlanks) - b + 1);
}

// The non-empty runs between separators.
inline std::vector<std::string_view> split_fields(std::string_view s, std::string_view separators = kBlanks) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    const std::size_t b = s.find_first_not_of(separators, i);
    if (b == std::string_view::npos) break;
    const std::size_t e = std::min(s.find_first_of(separators, b), s.size());
    out.push_back(s.substr(b, e - b));
    i = e;
  }
  return out;
}

// A whole token (blanks around it and a leading '+' allowed) as a number; false if it is not one.
inline bool parse_number(std::string_view s, double& v) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && end == s.data() + s.size();
}

// For messages: at most max_chars of the text, control and non-ASCII bytes shown as '?'.
inline std::string printable(std::string_view s, std::size_t max_chars = 200) {
  std::string out(s.substr(0, max_chars));
  for (auto& ch : out)
    if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) > 0x7e) ch = '?';
  return out;
}

inline std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// Whether s ends with `lower_suffix` (given in lower case), ignoring the case of s.
inline bool ends_with_ci(std::string_view s, std::string_view lower_suffix) {
  if (s.size() < lower_suffix.size()) return false;
  const std::string_view tail = s.substr(s.size() - lower_suffix.size());
  for (std::size_t i = 0; i < tail.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(tail[i])) != lower_suffix[i]) return false;
  return true;
}

// The lines of a text without their line breaks (\n or \r\n), numbered from 1.
class LineReader {
public:
  explicit LineReader(std::string_view text) : text_(text) {}
  // The next line; false at the end of the text.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    std::size_t eol = text_.find('\n', pos_);
    if (eol == std::string_view::npos) eol = text_.size();
    line = text_.substr(pos_, eol - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = eol + 1;
    ++line_no_;
    return true;
  }
  std::size_t line_no() const { return line_no_; }  // of the line last returned
  std::string where() const { return "line " + std::to_string(line_no_); }

private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_no_ = 0;
};

}  // namespace penumbra::io_detail
