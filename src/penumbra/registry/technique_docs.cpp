#include "penumbra/registry/technique_docs.h"

#include "penumbra/core/error.h"
#include "penumbra/registry/technique_catalog.h"

namespace penumbra {
namespace {

std::string kinds_text(KindMask kinds) {
  std::string s;
  for (int i = 0; i < kObjectKinds; ++i)
    if (kinds & kind_bit(static_cast<ObjectKind>(i))) s += (s.empty() ? "" : ", ") + to_string(static_cast<ObjectKind>(i));
  return s;
}

// Markdown table cells hold no '|'.
std::string cell(std::string text) {
  for (std::size_t i = 0; (i = text.find('|', i)) != std::string::npos; i += 2) text.replace(i, 1, "\\|");
  return text;
}

}  // namespace

std::string technique_keys_markdown() {
  std::string md;
  for (const TechniqueInfo* t : technique_catalog()) {
    if (t->name == "none") continue;
    const std::string section = to_string(t->family);
    md += "\n#### `" + section + ".technique`: `" + t->name + "`\n\n" + t->summary + ". ";
    md += (t->family == TechniqueFamily::Shadow ? "Casters: " : "Occluders: ") + kinds_text(t->casters) + ".";
    if (t->needs.extinction_sat) md += " Reads the extinction SAT (`light_cache.resolution`).";
    md += "\n\n";
    if (t->params.empty()) {
      md += "No keys.\n";
      continue;
    }
    md += "| key | type | default | allowed | unit | meaning |\n|---|---|---|---|---|---|\n";
    for (const ParamSpec& p : t->params)
      md += "| `" + section + "." + p.key + "` | " + p.type_text() + " | " + cell(p.default_text()) + " | " + cell(p.allowed_text()) + " | " +
            cell(p.unit) + " | " + cell(p.meaning) + " |\n";
  }
  return md;
}

namespace {

struct Span {
  std::size_t begin, end;  // the text strictly between the marker lines
};

Span section_span(const std::string& page, const std::string& what) {
  const std::size_t b = page.find(kTechniqueDocsBegin);
  const std::size_t e = page.find(kTechniqueDocsEnd);
  if (b == std::string::npos || e == std::string::npos || e < b)
    throw Error(what + ": the markers of the generated technique keys are missing (" + std::string(kTechniqueDocsBegin) + " ... " +
                kTechniqueDocsEnd + ")");
  const std::size_t after_begin = page.find('\n', b);
  return {after_begin == std::string::npos ? page.size() : after_begin + 1, e};
}

}  // namespace

std::string generated_section(const std::string& page, const std::string& what) {
  const Span s = section_span(page, what);
  return page.substr(s.begin, s.end - s.begin);
}

std::string with_generated_section(const std::string& page, const std::string& what) {
  const Span s = section_span(page, what);
  return page.substr(0, s.begin) + technique_keys_markdown() + "\n" + page.substr(s.end);
}

}  // namespace penumbra
