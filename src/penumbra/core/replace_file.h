// Writing an output file so that a failure leaves nothing half-written under its name: the bytes go to
// a temporary file beside it (".NAME.partial"), which is renamed into place once complete and removed
// when anything fails. Every file penumbra writes (images, EXR, stats, scenes, positions) goes through it.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace penumbra {

// Calls write(temporary) to fill the temporary file, then renames it to `path`. When write throws or
// the rename fails, the temporary file is removed and the error propagates. Errors do not name `path`:
// the caller gives the context (with_context), as for its other errors about the file.
void replace_file(const std::string& path, const std::function<void(const std::string& temporary)>& write);

// `bytes` as the whole content of `path`; an Error with the reason when it cannot be written (a missing
// folder, no permission, a full disk).
void replace_file_contents(const std::string& path, std::string_view bytes);

}  // namespace penumbra
