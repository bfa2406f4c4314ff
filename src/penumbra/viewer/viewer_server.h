// The viewer's server (docs/viewer.md): HTTP and WebSocket on one port with Boost.Beast (Debian's
// libboost-dev, header-only). Beast was chosen because one library speaks both HTTP and WebSocket, on
// Asio's event loop, so that the page, its downloads and the frame stream share one port and one
// token check. cpp-httplib has no WebSocket, and websocketpp would need a second library for HTTP.
//
// One network thread runs the event loop; one render thread owns the engine. Client messages are
// queued for the render thread. A new edit cancels a full frame in progress. Frames go to every
// connected page, and a frame still waiting to be sent is replaced by a newer one, never queued behind
// it. Every request must carry the token. No request names a file: edits that name files (a volume's
// "file", a ParaView colour map) are refused unless the file lies inside the data root.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "penumbra/engine/engine.h"

namespace penumbra {

struct ViewerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;          // 0: a free port
  std::string token;               // empty: a random 128-bit token
  std::string data_root;           // the only folder edits may name files in
  std::size_t max_message_bytes = 64 * 1024;
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

  // http://HOST:PORT/?token=TOKEN
  std::string url() const;
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
