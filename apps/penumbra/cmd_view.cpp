// `penumbra view (SCENE.json | DATA_FILE...) [--port P] [--host H] [--token T | --token-file PATH]
//  [--allow-origin ORIGIN ...] [--stall-limit S] [--data-root DIR] [--set key=value ...] [--raw-* ...]`: the viewer's
// server (viewer/viewer_server.h, docs/viewer.md). The first line on stdout is the URL to open, token
// included.
#include <cstdio>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

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
  int stall_limit_s = 30;
  std::string token_file;
};

// The token from --token, else the first line of --token-file, else PENUMBRA_VIEW_TOKEN, else ""
// (a random one). A file or the environment keep it out of the command line, which `ps` shows to
// every user of the machine.
std::string chosen_token(const ViewOptions& o) {
  if (!o.server.token.empty()) return o.server.token;
  if (!o.token_file.empty()) {
    std::ifstream in(o.token_file);
    std::string line;
    if (!in || !std::getline(in, line)) throw Error("--token-file " + o.token_file + ": cannot read a line from it (expected the token on its first line)");
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();  // a trailing newline, "\r"
    return line;
  }
  const char* env = std::getenv("PENUMBRA_VIEW_TOKEN");
  return env ? env : "";
}

void run_view(const ViewOptions& o) {
  ViewerOptions options = o.server;
  options.port = static_cast<std::uint16_t>(o.port);
  options.stall_limit = std::chrono::seconds(o.stall_limit_s);
  options.token = chosen_token(o);
  if (options.data_root.empty())  // the scene's or the first data file's folder
    options.data_root = std::filesystem::absolute(o.in.inputs.front()).parent_path().string();
  ViewerServer server(open_inputs(o.in), options);
  std::printf("%s\n", server.url().c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "penumbra view: serving %s (Ctrl-C stops)\n", server.url().c_str());
  if (server.listens_on_all_interfaces())
    std::fprintf(stderr, "penumbra view: listening on all interfaces (%s): from another machine, use this machine's name or address in place of the loopback address\n",
                 o.server.host.c_str());
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
  auto* token = cmd->add_option("--token", o->server.token, "Access token every request must carry, 16 characters or more (default: a random one; shown by ps: prefer --token-file or PENUMBRA_VIEW_TOKEN)");
  cmd->add_option("--token-file", o->token_file, "File whose first line is the token (keeps it out of ps)")->excludes(token);
  cmd->add_option("--allow-origin", o->server.allow_origins, "Another page's origin (http(s)://HOST:PORT) that may open the viewer's WebSocket and name it in Host; repeatable")
      ->allow_extra_args(false);  // one origin an occurrence: the inputs that follow stay inputs
  cmd->add_option("--stall-limit", o->stall_limit_s, "Seconds a client may leave the server's messages unread (its socket full) before it is closed")
      ->check(CLI::Range(1, 3600));
  cmd->add_option("--data-root", o->server.data_root, "The only folder edits may name files in (default: the scene's or first data file's folder)");
  cmd->callback([o] { run_view(*o); });
}

}  // namespace penumbra::cli
