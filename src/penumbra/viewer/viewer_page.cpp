#include "penumbra/viewer/viewer_page.h"

namespace penumbra {

namespace {

void replace_all(std::string& text, std::string_view from, std::string_view to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) text.replace(at, from.size(), to);
}

}  // namespace

const PageFile* find_page_file(std::string_view path) {
  for (const PageFile& file : viewer_page_files())
    if (file.path == path) return &file;
  return nullptr;
}

std::string page_html(const std::string& token) {
  std::string imports;
  for (const PageFile& file : viewer_page_files())
    if (file.path.ends_with(".js"))
      imports += (imports.empty() ? "" : ", ") + ("\"" + std::string(file.path) + "\": \"" + std::string(file.path) + "?token=" + token + "\"");
  std::string html(find_page_file("/")->body);
  replace_all(html, "{{import_map}}", "{\"imports\": {" + imports + "}}");
  replace_all(html, "{{token}}", token);
  return html;
}

std::string with_nonce(std::string html, std::string_view nonce) {
  replace_all(html, "{{nonce}}", nonce);
  return html;
}

}  // namespace penumbra
