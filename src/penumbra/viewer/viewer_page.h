#pragma once
// The viewer's page (src/penumbra/viewer/page/), compiled in by CMake (cmake/viewer_page.cmake).

#include <span>
#include <string_view>

namespace penumbra {

struct PageFile {
  std::string_view path;  // "/" for index.html, else its path under page/: "/style.css", "/js/main.js"
  std::string_view type;  // the Content-Type it is served with
  std::string_view body;
};

// Every file of the page, sorted by its path under page/.
std::span<const PageFile> viewer_page_files();

}  // namespace penumbra
