// Python's fnmatch.fnmatchcase, which MDAnalysis applies to name, type, resname, segid and chainID
// values: `*` any run of characters, `?` one character, `[seq]` one of seq (ranges a-z allowed),
// `[!seq]` none of them; case-sensitive; everything else literal.
#pragma once

#include <string_view>

namespace penumbra {

bool matches_name_pattern(std::string_view text, std::string_view pattern);

}  // namespace penumbra
