// `penumbra techniques [--markdown] [--update-doc FILE]`: every shadow and ambient technique with the
// keys it reads, from the techniques' own declarations (registry/registry.h).
#include <cstdio>
#include <fstream>
#include <sstream>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/registry/technique_docs.h"

namespace penumbra::cli {

void add_techniques_command(CLI::App& app) {
  struct Options {
    bool markdown = false;
    std::string update_doc;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("techniques", "List the shadow and ambient techniques and the keys each reads");
  cmd->add_flag("--markdown", o->markdown, "Print the key tables of docs/scene-file.md");
  cmd->add_option("--update-doc", o->update_doc, "Write the key tables between the markers of this page (docs/scene-file.md)");
  cmd->callback([o] {
    if (!o->update_doc.empty()) {
      std::ifstream in(o->update_doc, std::ios::binary);
      if (!in) throw Error(o->update_doc + ": cannot open the file");
      std::ostringstream page;
      page << in.rdbuf();
      const std::string updated = with_generated_section(page.str(), o->update_doc);
      with_context(o->update_doc, [&] { replace_file_contents(o->update_doc, updated); });
      std::printf("wrote the technique keys into %s\n", o->update_doc.c_str());
      return;
    }
    if (o->markdown) {
      std::fputs(technique_keys_markdown().c_str(), stdout);
      return;
    }
    for (const TechniqueInfo* t : technique_catalog()) {
      std::printf("%s.technique = %s: %s\n", to_string(t->family).c_str(), t->name.c_str(), t->summary.c_str());
      for (const ParamSpec& p : t->params)
        std::printf("  %-14s %-7s default %-12s %s%s%s: %s\n", p.key.c_str(), p.type_text().c_str(), p.default_text().c_str(), p.allowed_text().c_str(),
                    p.unit.empty() ? "" : " ", p.unit.c_str(), p.meaning.c_str());
    }
  });
}

}  // namespace penumbra::cli
