// The key tables of docs/scene-file.md, generated from the techniques' declarations (registry.h):
// `penumbra techniques --markdown` prints them, `--update-doc FILE` writes them between the markers,
// and tests/test_technique_docs.cpp fails when the committed page differs from what the declarations
// say.
#pragma once

#include <string>

namespace penumbra {

inline constexpr const char* kTechniqueDocsBegin =
    "<!-- technique keys: generated from each technique's declaration by `penumbra techniques --update-doc docs/scene-file.md` -->";
inline constexpr const char* kTechniqueDocsEnd = "<!-- end of the technique keys -->";

// One section per registered technique: its summary, the kinds it takes, and a table of its keys
// (type, default, allowed values, unit, meaning).
std::string technique_keys_markdown();

// The lines between the markers of a page's text (Error naming `what` when they are missing).
std::string generated_section(const std::string& page, const std::string& what);
// The page with the lines between the markers replaced by technique_keys_markdown().
std::string with_generated_section(const std::string& page, const std::string& what);

}  // namespace penumbra
