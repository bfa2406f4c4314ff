// `penumbra view (SCENE.json | DATA_FILE...) [--port P] [--host H] [--token T] [--data-root DIR]
//  [--set key=value ...] [--raw-* ...]`: the viewer's server (viewer/viewer_server.h, docs/viewer.md).
// The first line on stdout is the URL to open, token included.
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "inputs.h"
#include "penumbra/core/error.h"
#include "penumbra/viewer/viewer_server.h"

namespace penumbra::cli {
namespace {

struct ViewOptions {
  InputOptions in;
  ViewerOptions server;
  int port = 0;
};

void run_view(const ViewOptions& o) {
  ViewerOptions options = o.server;
  options.port = static_cast<std::uint16_t>(o.port);
  if (options.data_root.empty())  // the scene's or the first data file's folder
    options.data_root = std::filesystem::absolute(o.in.inputs.front()).parent_path().string();
  ViewerServer server(open_inputs(o.in), options);
  std::printf("%s\n", server.url().c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "penumbra view: serving %s (Ctrl-C stops)\n", server.url().c_str());
  server.run();
  std::fprintf(stderr, "penumbra view: stopped\n");
}

}  // namespace

void add_view_command(CLI::App& app) {
  auto o = std::make_shared<ViewOptions>();
  CLI::App* cmd = app.add_subcommand("view", "Explore a scene or data files in a browser: the server renders, the page shows the frames and sends input back");
  add_input_options(*cmd, o->in);
  cmd->add_option("--port", o->port, "TCP port (0: a free one)")->check(CLI::Range(0, 65535));
  cmd->add_option("--host", o->server.host, "Address to bind (default 127.0.0.1: this machine only)");
  cmd->add_option("--token", o->server.token, "Access token every request must carry (default: a random one)");
  cmd->add_option("--data-root", o->server.data_root, "The only folder edits may name files in (default: the scene's or first data file's folder)");
  cmd->callback([o] { run_view(*o); });
}

}  // namespace penumbra::cli
