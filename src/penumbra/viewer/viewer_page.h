#pragma once
// The viewer's page (src/penumbra/viewer/page/), compiled in by CMake (cmake/viewer_page.cmake).

#include <span>
#include <string>
#include <string_view>

namespace penumbra {

struct PageFile {
  std::string_view path;  // "/" for index.html, else its path under page/: "/style.css", "/js/main.js"
  std::string_view type;  // the Content-Type it is served with
  std::string_view body;
};

// Every file of the page, sorted by its path under page/ (the generated viewer_page.cpp).
std::span<const PageFile> viewer_page_files();

// The file served at `path`, or null: only the table's paths are served, and no request reads a file.
const PageFile* find_page_file(std::string_view path);

// index.html with every placeholder filled in except the nonce (with_nonce, per answer): the token of
// the stylesheet's and the main module's URLs, and the import map that gives every module its URL with the token (a module's
// `import "./view.js"` asks for /js/view.js, which the map turns into /js/view.js?token=T).
std::string page_html(const std::string& token);

// `html` with the nonce of the answer's Content-Security-Policy, which lets its import map run.
std::string with_nonce(std::string html, std::string_view nonce);

}  // namespace penumbra
