// The viewer's server (docs/viewer.md): HTTP and WebSocket on one port with Boost.Beast (Debian's
// libboost-dev, header-only). Beast was chosen because one library speaks both HTTP and WebSocket, on
// Asio's event loop, so that the page, its downloads and the frame stream share one port and one
// token check. cpp-httplib has no WebSocket, and websocketpp would need a second library for HTTP.
//
// One network thread runs the event loop; one render thread owns the engine. Client messages are
// queued for the render thread. A new edit cancels a full frame in progress. Frames go to every
// connected page, and a frame still waiting to be sent is replaced by a newer one, never queued behind
// it. Every request must carry the token and a Host header naming this server; a WebSocket must come
// from the server's own page (Origin). No request names a file: edits that name files (a volume's
// "file", a ParaView colour map) are refused unless the file lies inside the data root, and so are the
// files those files name. Each client's queue is bounded (client_queue.h), connections are capped
// below the descriptor limit. The checks themselves are viewer_security.h's.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/engine/engine.h"

namespace penumbra {

struct ViewerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;          // 0: a free port
  std::string token;               // empty: a random 128-bit token; else at least 16 characters
  std::string data_root;           // the only folder edits may name files in
  std::vector<std::string> allow_origins;  // other pages (http(s)://HOST:PORT) that may open the WebSocket
  // The pages that may show the viewer in a frame, as CSP frame-ancestors sources (http://localhost:*);
  // empty: none (X-Frame-Options DENY). Python's penumbra.view sets the local notebook servers.
  std::vector<std::string> frame_ancestors;
  std::size_t max_message_bytes = 64 * 1024;
  std::size_t max_connections = 64;  // less where the descriptor limit (RLIMIT_NOFILE) leaves less room
  std::chrono::seconds stall_limit{30};  // a client whose socket takes no data this long is closed
  int max_samples = 16;            // accumulated full-quality samples while idle
  bool stop_on_signals = true;     // SIGINT / SIGTERM stop run() (not inside a host like Python)
};

class ViewerServer {
public:
  // Binds and listens (Error naming the address when it cannot); nothing runs until run().
  ViewerServer(Engine engine, ViewerOptions options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  // http://HOST:PORT/?token=TOKEN; bound to all interfaces (0.0.0.0, ::), the loopback address
  std::string url() const;
  bool listens_on_all_interfaces() const;
  std::uint16_t port() const;
  const std::string& token() const;

  // Serves until stop() (from any thread, or a signal handler through the event loop).
  void run();
  void stop();

  struct Impl;

private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
