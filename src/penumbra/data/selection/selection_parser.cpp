// The selection parser: MDAnalysis's tokens (the text split at blanks, parentheses apart), its
// precedence climbing (`and` and `or` of equal precedence, left to right; `not` binding tighter;
// `around`, `sphzone`, `byres`, `same … as` taking everything after them), its value lists (values
// run until the next MDAnalysis keyword) and its ranges ("10:20", "10-20", "10 to 20", blanks allowed
// around the separator). Errors give the 1-based character where the parser stopped and what it expected.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <charconv>
#include <optional>
#include <string_view>

#include "penumbra/core/error.h"
#include "penumbra/data/selection/selection.h"

namespace penumbra {
namespace {

using Kind = SelectionNode::Kind;

struct SelectionToken {
  std::string text;
  std::size_t column = 0;  // 1-based position in the selection text
  bool end = false;
};

std::vector<SelectionToken> tokenize_selection(const std::string& text) {
  std::vector<SelectionToken> tokens;
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (c == '(' || c == ')') {
      tokens.push_back({std::string(1, c), i + 1});
      ++i;
    } else {
      const std::size_t start = i;
      while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i])) && text[i] != '(' && text[i] != ')') ++i;
      tokens.push_back({text.substr(start, i - start), start + 1});
    }
  }
  tokens.push_back({"", text.size() + 1, true});
  return tokens;
}

// Every keyword of MDAnalysis 2.4's selection language (its _SELECTIONDICT and operators): a value
// list ends at any of them, supported here or not.
bool is_mdanalysis_keyword(const SelectionToken& t) {
  static const char* const kKeywords[] = {
      "all", "altLoc", "altloc", "aromatic", "aromaticity", "around", "atom", "backbone", "bfactor", "bonded", "bynum",
      "byres", "chainID", "chainid", "charge", "chirality", "cylayer", "cyzone", "element", "epsilon", "epsilon14",
      "formalcharge", "gbscreen", "global", "group", "icode", "id", "index", "isolayer", "mass", "model", "molnum",
      "moltype", "name", "nbindex", "not", "nucleic", "nucleicbackbone", "nucleicbase", "nucleicsugar", "occupancy",
      "point", "prop", "protein", "radius", "record_type", "resid", "resindex", "resname", "resnum", "rmin", "rmin14",
      "same", "segid", "segindex", "smarts", "solventradius", "sphlayer", "sphzone", "tempfactor", "type", "and", "or",
      "(", ")"};
  return t.end || std::any_of(std::begin(kKeywords), std::end(kKeywords), [&](const char* k) { return t.text == k; });
}

// One value of a numeric keyword, read as MDAnalysis's patterns do: "-?\d+" alone (resid: with an
// optional insertion code, one word character, after it), or a range: two of them separated by ':',
// '-' or ' to ' with blanks allowed around; what follows the second number is ignored (MDAnalysis's
// re.match has no end anchor there).
struct NumberValue {
  std::string_view lo, hi;
  bool range = false, insertion_code = false;
};

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }
bool is_blank(char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }

// "-?\d+" at s[i], i moved past it.
std::optional<std::string_view> scan_integer(std::string_view s, std::size_t& i) {
  std::size_t j = i;
  if (j < s.size() && s[j] == '-') ++j;
  const std::size_t digits = j;
  while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
  if (j == digits) return std::nullopt;
  const std::string_view number = s.substr(i, j - i);
  i = j;
  return number;
}

std::optional<NumberValue> number_value(std::string_view s, bool insertion_codes) {
  NumberValue v;
  std::size_t i = 0;
  const auto lo = scan_integer(s, i);
  if (!lo) return std::nullopt;
  v.lo = v.hi = *lo;
  if (insertion_codes && i < s.size() && is_word_char(s[i])) {
    v.insertion_code = true;
    ++i;
  }
  if (i == s.size()) return v;
  std::size_t j = i;
  while (j < s.size() && is_blank(s[j])) ++j;
  if (j < s.size() && (s[j] == ':' || s[j] == '-')) {
    ++j;
  } else if (j > i && s[j - 1] == ' ' && s.substr(j, 3) == "to ") {
    j += 3;
  } else {
    return std::nullopt;
  }
  while (j < s.size() && is_blank(s[j])) ++j;
  const auto hi = scan_integer(s, j);
  if (!hi) return std::nullopt;
  v.hi = *hi;
  v.range = true;
  if (insertion_codes && j < s.size() && is_word_char(s[j])) v.insertion_code = true;
  return v;
}

std::string found_text(const SelectionToken& t) { return t.end ? "the end of the selection" : "'" + t.text + "'"; }

class SelectionParser {
public:
  explicit SelectionParser(const std::string& text) : tokens_(tokenize_selection(text)) {}

  // Bounds that keep the recursion of parsing, evaluating and freeing a selection shallow.
  static constexpr std::size_t kMaxTokens = 10000;
  static constexpr int kMaxNesting = 100;

  std::unique_ptr<SelectionNode> parse() {
    if (tokens_.size() > kMaxTokens + 1)
      fail_at(tokens_[kMaxTokens], "at most " + std::to_string(kMaxTokens) + " words and parentheses in a selection");
    auto root = expression(0);
    if (!peek().end) fail("'and', 'or' or the end of the selection");
    return root;
  }
  bool geometric = false;

private:
  std::vector<SelectionToken> tokens_;
  std::size_t next_ = 0;
  int nesting_ = 0;  // expressions being parsed, one inside the other

  const SelectionToken& peek() const { return tokens_[next_]; }
  const SelectionToken& take() { return tokens_[next_ == tokens_.size() - 1 ? next_ : next_++]; }
  [[noreturn]] void fail(const std::string& expected) const { fail_at(peek(), expected); }
  [[noreturn]] static void fail_at(const SelectionToken& t, const std::string& expected) {
    throw Error("at character " + std::to_string(t.column) + ": expected " + expected + ", found " + found_text(t));
  }

  static int precedence(const SelectionToken& t) { return !t.end && (t.text == "and" || t.text == "or") ? 3 : -1; }

  std::unique_ptr<SelectionNode> expression(int min_precedence) {
    if (++nesting_ > kMaxNesting)
      fail("at most " + std::to_string(kMaxNesting) + " levels of nesting (parentheses, not, around, sphzone, within, byres, same … as)");
    auto left = subexpression();
    while (precedence(peek()) >= min_precedence) {
      const Kind kind = take().text == "and" ? Kind::And : Kind::Or;
      auto node = std::make_unique<SelectionNode>();
      node->kind = kind;
      node->children.push_back(std::move(left));
      node->children.push_back(expression(3 + 1));
      left = std::move(node);
    }
    --nesting_;
    return left;
  }

  static std::unique_ptr<SelectionNode> leaf(Kind kind) {
    auto n = std::make_unique<SelectionNode>();
    n->kind = kind;
    return n;
  }

  std::unique_ptr<SelectionNode> subexpression() {
    const SelectionToken t = take();
    if (t.end) fail_at(t, "a selection (a keyword such as all, protein, name, resid, around, or '(')");
    if (t.text == "(") {
      auto inner = expression(0);
      if (peek().text != ")" || peek().end) fail("')' closing the '(' at character " + std::to_string(t.column));
      take();
      return inner;
    }
    const std::string& k = t.text;
    if (k == "all") return leaf(Kind::All);
    if (k == "none") return leaf(Kind::None);
    if (k == "protein") return leaf(Kind::Protein);
    if (k == "backbone") return leaf(Kind::Backbone);
    if (k == "nucleic") return leaf(Kind::Nucleic);
    if (k == "water") return leaf(Kind::Water);
    if (k == "not") return unary(Kind::Not, 5);
    if (k == "byres") return same_as("residue", 1);
    if (k == "name") return strings(Kind::Name, t);
    if (k == "type") return strings(Kind::Type, t);
    if (k == "resname") return strings(Kind::Resname, t);
    if (k == "segid") return strings(Kind::Segid, t);
    if (k == "chainID" || k == "chainid") return strings(Kind::ChainId, t);
    if (k == "resid") return numbers(Kind::Resid, t, true);
    if (k == "resnum") return numbers(Kind::Resnum, t, false);
    if (k == "index") return numbers(Kind::Index, t, false);
    if (k == "bynum") return numbers(Kind::Bynum, t, false);
    if (k == "around" || k == "sphzone") {
      auto n = leaf(k == "around" ? Kind::Around : Kind::Sphzone);
      n->distance = distance();
      n->children.push_back(expression(1));
      geometric = true;
      return n;
    }
    if (k == "within") {  // VMD: within D of SEL
      auto n = leaf(Kind::Within);
      n->distance = distance();
      if (peek().text != "of" || peek().end) fail("'of' (VMD's 'within D of SELECTION')");
      take();
      n->children.push_back(expression(1));
      geometric = true;
      return n;
    }
    if (k == "same") {
      const SelectionToken& prop = peek();
      static const char* const kProps[] = {"residue", "name", "type", "resname", "resid", "resnum", "segid"};
      if (prop.end || std::none_of(std::begin(kProps), std::end(kProps), [&](const char* p) { return prop.text == p; }))
        fail("a property after 'same' (residue, name, type, resname, resid, resnum or segid)");
      const std::string property = take().text;
      if (peek().text != "as" || peek().end) fail("'as' (same " + property + " as SELECTION)");
      take();
      return same_as(property, 1);
    }
    if (is_mdanalysis_keyword(t))
      fail_at(t, "a keyword penumbra supports (MDAnalysis's '" + k + "' is not one: see docs/selections.md)");
    fail_at(t, "a selection keyword (all, none, protein, backbone, nucleic, water, name, type, resname, resid, resnum, "
               "segid, chainID, index, bynum, around, sphzone, within, same, byres, not, '(')");
  }

  std::unique_ptr<SelectionNode> unary(Kind kind, int p) {
    auto n = leaf(kind);
    n->children.push_back(expression(p));
    return n;
  }
  std::unique_ptr<SelectionNode> same_as(const std::string& property, int p) {
    auto n = unary(Kind::SameAs, p);
    n->property = property;
    return n;
  }

  double distance() {
    const SelectionToken& t = peek();
    const char* begin = t.text.c_str();
    char* end = nullptr;
    const double d = t.end ? NAN : std::strtod(begin, &end);
    if (t.end || end == begin || *end != '\0' || !std::isfinite(d) || d < 0) fail("a distance in Å (a number ≥ 0)");
    take();
    return d;
  }

  // MDAnalysis's grab_not_keywords: the tokens up to the next keyword, at least one.
  std::vector<SelectionToken> values(const SelectionToken& keyword) {
    std::vector<SelectionToken> v;
    while (!is_mdanalysis_keyword(peek())) v.push_back(take());
    if (v.empty()) fail("a value after '" + keyword.text + "'");
    return v;
  }

  std::unique_ptr<SelectionNode> strings(Kind kind, const SelectionToken& keyword) {
    auto n = leaf(kind);
    for (const SelectionToken& v : values(keyword)) n->patterns.push_back(v.text);
    return n;
  }

  // MDAnalysis's join_separated_values: "10", ":", "20" or "10", "to", "20" or "10:", "20" become one
  // value "10 : 20".
  static std::vector<SelectionToken> joined(std::vector<SelectionToken> v) {
    std::vector<SelectionToken> out;
    const auto ends_with_delimiter = [](const std::string& s) {
      return s.back() == ':' || s.back() == '-' || (s.size() >= 2 && s.compare(s.size() - 2, 2, "to") == 0);
    };
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string& s = v[i].text;
      if (s == "to" || s == ":" || s == "-") {
        if (out.empty() || i + 1 == v.size()) fail_at(v[i], "a number on both sides of the range separator '" + s + "'");
        out.back().text += " " + s + " " + v[++i].text;
      } else if (!out.empty() && (s.compare(0, 2, "--") == 0 || s.compare(0, 2, "to") == 0 || s[0] == ':' ||
                                  ends_with_delimiter(out.back().text))) {
        out.back().text += " " + s;
      } else {
        out.push_back(v[i]);
      }
    }
    return out;
  }

  std::unique_ptr<SelectionNode> numbers(Kind kind, const SelectionToken& keyword, bool resid) {
    auto n = leaf(kind);
    for (const SelectionToken& v : joined(values(keyword))) {
      const std::optional<NumberValue> value = number_value(v.text, resid);
      if (!value) fail_at(v, "a number or a range ('10:20', '10-20', '10 to 20') after '" + keyword.text + "'");
      if (value->insertion_code)
        fail_at(v, value->range ? "a residue range without insertion codes (the topology has none)"
                                : "a residue number without an insertion code (the topology has none)");
      const auto number = [&](std::string_view digits) {
        std::int64_t x = 0;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), x);
        if (ec != std::errc() || end != digits.data() + digits.size()) fail_at(v, "a number that fits 64 bits");
        return x;
      };
      n->ranges.emplace_back(number(value->lo), number(value->hi));
    }
    return n;
  }
};

}  // namespace

std::shared_ptr<const AtomSelection> parse_selection(const std::string& text) {
  SelectionParser parser(text);
  auto selection = std::make_shared<AtomSelection>();
  selection->root_ = parser.parse();
  selection->text_ = text;
  selection->geometric_ = parser.geometric;
  return selection;
}

}  // namespace penumbra
