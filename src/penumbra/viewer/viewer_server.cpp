#include "penumbra/viewer/viewer_server.h"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <sys/resource.h>
#include <unistd.h>

#include "penumbra/core/cancel.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/timer.h"
#include "penumbra/scene_io/json_reader.h"
#include "penumbra/viewer/client_queue.h"
#include "penumbra/viewer/frame_message.h"
#include "penumbra/viewer/probe.h"
#include "penumbra/viewer/viewer_page.h"
#include "penumbra/viewer/viewer_security.h"
#include "penumbra/viewer/viewer_state.h"

namespace penumbra {

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Text = std::shared_ptr<const std::string>;

// File descriptors kept free of connections: the render thread's files (volumes, /proc/self/statm),
// the event loop's own, and a margin, so that a flood of connections never starves them.
constexpr std::size_t kReservedDescriptors = 32;
// How long the accept loop waits after accept() failed (out of descriptors: EMFILE, ENFILE) before it
// tries again, rather than spinning on a failure that repeats until a descriptor is freed.
constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(100);
// A client's messages waiting for the render thread at most: past it, its next message is not read
// until one is applied, so a client sending faster than the engine edits fills its own socket, not
// the server's memory.
constexpr int kMaxQueuedMessages = 8;

std::string random_token() {
  std::random_device device;
  char hex[33];
  for (int i = 0; i < 4; ++i) std::snprintf(hex + 8 * i, 9, "%08x", device());
  return hex;
}

bool same_secret(std::string_view a, std::string_view b) {  // without an early exit on the first difference
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

// The path of a request target and its `token` query parameter.
std::pair<std::string, std::string> split_target(std::string_view target) {
  const auto q = target.find('?');
  std::string path(target.substr(0, q));
  std::string token;
  if (q != std::string_view::npos) {
    std::string_view query = target.substr(q + 1);
    while (!query.empty()) {
      const auto amp = query.find('&');
      const std::string_view param = query.substr(0, amp);
      if (param.rfind("token=", 0) == 0) token = std::string(param.substr(6));
      if (amp == std::string_view::npos) break;
      query.remove_prefix(amp + 1);
    }
  }
  return {path, token};
}

// An error reply; bytes of the offending message that are not UTF-8 are replaced, not thrown on.
Text error_message(const std::string& message) {
  return std::make_shared<const std::string>(
      nlohmann::json{{"type", "error"}, {"message", message}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

// The key a value at `path` belongs to: the path's last part that is not a list index
// ("volumes.0.files.2" is an element of "files").
std::string owning_key(std::string path) {
  while (true) {
    const std::size_t dot = path.rfind('.');
    const std::string part = dot == std::string::npos ? path : path.substr(dot + 1);
    const bool index = !part.empty() && std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
    if (!index) return part;
    if (dot == std::string::npos) return "";
    path.resize(dot);
  }
}

// The connections the descriptor limit leaves room for (RLIMIT_NOFILE less kReservedDescriptors),
// at most `wanted`.
std::size_t connection_cap(std::size_t wanted) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return wanted;
  const std::size_t room = limit.rlim_cur > kReservedDescriptors + 4 ? static_cast<std::size_t>(limit.rlim_cur) - kReservedDescriptors : 4;
  return std::min(wanted, room);
}

}  // namespace

class WsSession;
class HttpSession;

struct ViewerServer::Impl {
  struct Job {
    // The client whose message this is. Held, not watched: a client whose reading is paused (it has
    // kMaxQueuedMessages waiting here) and that has nothing in flight is kept alive by its jobs alone,
    // until message_applied() lets it read on.
    std::shared_ptr<WsSession> from;
    std::vector<std::pair<std::string, nlohmann::json>> edits;
    std::function<void()> task;  // a request that needs the engine (screenshot, saved scene)
    bool keeps_frame = false;    // a task that changes nothing drawn (a probe): refining goes on
    bool preview = true;         // an edit's frames start with a preview ("preview": false: the full frame only)
  };

  Engine engine;
  ViewerOptions options;
  std::filesystem::path data_root;
  viewer_security::Listener listener;
  std::string frame_ancestors;  // the CSP frame-ancestors value: the sources of options.frame_ancestors, or 'none'
  net::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  net::steady_timer accept_retry{ioc};
  // Open connections (HTTP and WebSocket), counted by the sessions themselves, which may end on the
  // render thread; and HTTP sessions by age, the network thread's only, to close the one idle longest
  // when a new connection needs its place.
  std::atomic<std::size_t> open_connections{0};
  std::size_t max_connections = 0;
  std::deque<std::weak_ptr<HttpSession>> http_sessions;
  ViewerState state;
  std::string page;  // index.html as served, but its nonce (page_html)

  std::mutex mutex;  // guards what follows
  std::condition_variable wake;
  std::deque<Job> jobs;
  bool stopping = false;
  std::vector<std::weak_ptr<WsSession>> sessions;
  Text last_state, last_frame_meta, last_frame_jpeg;
  std::atomic<bool> cancel{false};
  std::uint64_t frame_id = 0;

  Impl(Engine e, ViewerOptions o) : engine(std::move(e)), options(std::move(o)) {}

  void accept();
  void on_accepted(tcp::socket socket);
  // Closes the HTTP connection that has waited longest for a request; false when none waits.
  bool close_idle_http();
  // An error reply's text: the data root never shown (viewer_security::without_root).
  Text client_error(const std::string& message) const { return error_message(viewer_security::without_root(message, data_root)); }
  void render_loop();
  void render_frame(Quality quality, bool accumulate);
  void broadcast_state();
  void queue(Job job) {
    const bool job_keeps_frame = job.keeps_frame;
    {
      std::lock_guard lock(mutex);
      jobs.push_back(std::move(job));
    }
    if (!job_keeps_frame) cancel = true;  // a full frame in progress is stale now
    wake.notify_one();
  }
  // Refuses an edit that names a file outside the data root (an Error naming the path and the file).
  void check_files(const std::string& path, const nlohmann::json& value) const;
  void on_message(const std::shared_ptr<WsSession>& from, const std::string& text);
  std::vector<std::shared_ptr<WsSession>> live_sessions();
};

// ----------------------------------------------------------------------------------- WebSocket
class WsSession : public std::enable_shared_from_this<WsSession> {
public:
  WsSession(tcp::socket&& socket, ViewerServer::Impl& server) : ws_(std::move(socket)), stall_timer_(ws_.get_executor()), server_(server) {
    ++server_.open_connections;
  }
  ~WsSession() { --server_.open_connections; }

  void start(http::request<http::string_body> request) {
    ws_.read_message_max(server_.options.max_message_bytes);
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  // From any thread: posted onto the event loop. The client's queue keeps only the latest state and
  // frame (client_queue.h), so a client that reads slowly costs no more memory than a fast one.
  void send_state(Text text) {
    net::post(ws_.get_executor(), [self = shared_from_this(), text] {
      self->queue_.push_state(text);
      self->write_next();
    });
  }
  void send_error(Text text) {
    net::post(ws_.get_executor(), [self = shared_from_this(), text] {
      self->queue_.push_error(text);
      self->write_next();
    });
  }
  // A message of this client's went to the render thread (network thread) / was applied (any thread).
  void message_queued() { ++queued_messages_; }
  void message_applied() {
    net::post(ws_.get_executor(), [self = shared_from_this()] {
      --self->queued_messages_;
      if (self->read_paused_ && self->queued_messages_ < kMaxQueuedMessages) {
        self->read_paused_ = false;
        self->read();
      }
    });
  }
  void send_probe(Text text) {
    net::post(ws_.get_executor(), [self = shared_from_this(), text] {
      self->queue_.push_probe(text);
      self->write_next();
    });
  }
  // When the server stops, on the thread that ran its event loop (which has returned).
  void close_now() {
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }
  void send_frame(Text meta, Text jpeg) {
    net::post(ws_.get_executor(), [self = shared_from_this(), meta, jpeg] {
      self->queue_.push_frame(meta, jpeg);
      self->write_next();
    });
  }

private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    {
      std::lock_guard lock(server_.mutex);
      server_.sessions.push_back(weak_from_this());
      if (server_.last_state) queue_.push_state(server_.last_state);
      if (server_.last_frame_meta) queue_.push_frame(server_.last_frame_meta, server_.last_frame_jpeg);
    }
    write_next();
    read();
  }

  void read() { ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this())); }

  void on_read(beast::error_code ec, std::size_t) {
    // closed, too large (message_too_big), text that is not UTF-8 (RFC 6455 requires failing the
    // connection: close code 1007) or broken: the session ends; others go on
    if (ec) return;
    if (!ws_.got_text()) {
      send_error(error_message("expected a text message (JSON)"));
    } else {
      server_.on_message(shared_from_this(), beast::buffers_to_string(buffer_.data()));
    }
    buffer_.consume(buffer_.size());
    if (queued_messages_ >= kMaxQueuedMessages) read_paused_ = true;  // message_applied() reads on
    else read();
  }

  void write_next() {
    const ClientQueue::Message* m = queue_.start_next();
    if (!m) return;
    ws_.binary(m->binary);
    // a client that stops reading stalls this write once its socket's buffers are full: past the limit
    // it is closed, and its place and queue freed
    const std::uint64_t write = ++writes_;
    stall_timer_.expires_after(server_.options.stall_limit);
    stall_timer_.async_wait([weak = weak_from_this(), write](beast::error_code ec) {
      auto self = weak.lock();
      if (ec || !self || self->writes_ != write || self->queue_.idle()) return;
      beast::error_code ignored;
      beast::get_lowest_layer(self->ws_).socket().close(ignored);
    });
    ws_.async_write(net::buffer(*m->data), beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }
  void on_write(beast::error_code ec, std::size_t) {
    stall_timer_.cancel();
    if (ec) {  // the client went away (or stalled and was closed): forget what was queued for it
      queue_.clear();
      return;
    }
    queue_.written();
    write_next();
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  ClientQueue queue_;
  net::steady_timer stall_timer_;
  std::uint64_t writes_ = 0;  // which write the stall timer watches
  int queued_messages_ = 0;   // the network thread's, as read_paused_
  bool read_paused_ = false;
  ViewerServer::Impl& server_;
};

// ---------------------------------------------------------------------------------------- HTTP
class HttpSession : public std::enable_shared_from_this<HttpSession> {
  using Job = ViewerServer::Impl::Job;

public:
  HttpSession(tcp::socket&& socket, ViewerServer::Impl& server) : stream_(std::move(socket)), server_(server) { ++server_.open_connections; }
  ~HttpSession() { --server_.open_connections; }

  void start() { net::dispatch(stream_.get_executor(), beast::bind_front_handler(&HttpSession::read, shared_from_this())); }

  // Since when the connection has waited for a request (nullopt while one is being answered). The
  // network thread's only, as close_idle().
  std::optional<std::chrono::steady_clock::time_point> waiting_since() const { return waiting_since_; }
  void close_idle() {
    waiting_since_.reset();  // not chosen again before its read handler sees the close
    close_now();
  }
  // When the server stops, on the thread that ran its event loop (which has returned).
  void close_now() {
    beast::error_code ec;
    stream_.socket().close(ec);
  }

  // From the render thread: the answer to a request that needed the engine.
  void answer(http::status status, std::string body, std::string type, std::string filename) {
    net::post(stream_.get_executor(), [self = shared_from_this(), status, body = std::move(body), type = std::move(type), filename = std::move(filename)] {
      self->respond(status, body, type, filename);
    });
  }

private:
  void read() {
    parser_.emplace();
    parser_->body_limit(server_.options.max_message_bytes);
    parser_->header_limit(16 * 1024);
    stream_.expires_after(std::chrono::seconds(30));
    waiting_since_ = std::chrono::steady_clock::now();
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    waiting_since_.reset();
    if (ec == http::error::end_of_stream) return close();
    if (ec) {
      if (ec == http::error::body_limit || ec == http::error::header_limit) respond(http::status::payload_too_large, "request too large\n", "text/plain", "", false);
      return;
    }
    http::request<http::string_body> req = parser_->release();
    keep_alive_ = req.keep_alive();
    const auto [path, token] = split_target(std::string_view(req.target().data(), req.target().size()));
    // a page of another site reaching us through its own DNS name (DNS rebinding) names that in Host
    const std::string_view host(req[http::field::host].data(), req[http::field::host].size());
    if (!viewer_security::host_allowed(host, server_.listener))
      return respond(http::status::forbidden, "forbidden: Host " + viewer_security::json_quoted(host) + " is not this server's address (allowed: localhost, an IP address, with port " +
                                                  std::to_string(server_.listener.port) + ", or an --allow-origin)\n", "text/plain", "");
    if (!same_secret(token, server_.options.token)) return respond(http::status::forbidden, "forbidden: a valid token is required\n", "text/plain", "");
    if (websocket::is_upgrade(req)) {
      if (path != "/ws") return respond(http::status::not_found, "not found\n", "text/plain", "");
      // a browser tells which page opens the socket: only our own page (or an --allow-origin) may
      const std::string_view origin(req[http::field::origin].data(), req[http::field::origin].size());
      if (!viewer_security::origin_allowed(origin, host, server_.listener))
        return respond(http::status::forbidden, "forbidden: Origin " + viewer_security::json_quoted(origin) + " is not this server's page (add it with --allow-origin)\n", "text/plain", "");
      stream_.expires_never();
      std::make_shared<WsSession>(stream_.release_socket(), server_)->start(std::move(req));
      return;
    }
    if (req.method() != http::verb::get) return respond(http::status::method_not_allowed, "only GET\n", "text/plain", "");
    if (const PageFile* file = find_page_file(path)) {
      if (file->path != "/") return respond(http::status::ok, std::string(file->body), std::string(file->type), "");
      // the page's one inline script, its import map, runs by the nonce of this answer's policy
      const std::string nonce = random_token();
      return respond(http::status::ok, with_nonce(server_.page, nonce), std::string(file->type), "", true, nonce);
    }
    if (path == "/screenshot.png" || path == "/scene.json") {
      stream_.expires_after(std::chrono::minutes(10));  // a full frame of a large scene takes a while
      Job job;
      auto self = shared_from_this();
      job.task = [self, &server = server_, screenshot = path == "/screenshot.png"] {
        try {
          if (screenshot) {
            const EngineFrame f = server.engine.render({Quality::Full, false});  // sample 0: what `penumbra render` gives
            self->answer(http::status::ok, encode_png(f.image), "image/png", "penumbra.png");
          } else {
            self->answer(http::status::ok, server.engine.saved_document(server.data_root.string()).dump(2) + "\n", "application/json", "scene.json");
          }
        } catch (const std::exception& e) {
          self->answer(http::status::internal_server_error, viewer_security::without_root(e.what(), server.data_root) + "\n", "text/plain", "");
        }
      };
      server_.queue(std::move(job));
      return;
    }
    respond(http::status::not_found, "not found\n", "text/plain", "");
  }

  void respond(http::status status, const std::string& body, const std::string& type, const std::string& filename, bool keep = true,
               const std::string& nonce = "") {
    auto res = std::make_shared<http::response<http::string_body>>(status, 11);
    res->set(http::field::server, "penumbra");
    res->set(http::field::content_type, type);
    res->set(http::field::cache_control, "no-store");
    res->set("X-Content-Type-Options", "nosniff");
    // scripts and style only from the page's own files (and the page's import map, by its nonce); no
    // other site may frame the page (clickjacking): frame-ancestors, and X-Frame-Options for browsers
    // without it
    res->set("Content-Security-Policy", "default-src 'none'; script-src 'self'" + (nonce.empty() ? std::string() : " 'nonce-" + nonce + "'") +
                                            "; style-src 'self'; img-src 'self' blob: data:; connect-src 'self'; frame-ancestors " +
                                            server_.frame_ancestors);
    if (server_.options.frame_ancestors.empty()) res->set("X-Frame-Options", "DENY");  // it would overrule the sources
    if (!filename.empty()) res->set(http::field::content_disposition, "attachment; filename=\"" + filename + "\"");
    res->body() = body;
    res->keep_alive(keep && keep_alive_);
    res->prepare_payload();
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
      if (ec || !res->keep_alive()) return self->close();
      self->read();
    });
  }

  void close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  bool keep_alive_ = false;
  std::optional<std::chrono::steady_clock::time_point> waiting_since_;
  ViewerServer::Impl& server_;
};

// -------------------------------------------------------------------------------------- server
void ViewerServer::Impl::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted) return;
    if (!ec) {
      on_accepted(std::move(socket));
      return accept();
    }
    // Out of descriptors (EMFILE, ENFILE) or another failure that the next try would repeat at once:
    // free a descriptor held by an idle connection and wait before trying again, instead of spinning.
    close_idle_http();
    accept_retry.expires_after(kAcceptRetryDelay);
    accept_retry.async_wait([this](beast::error_code wait_ec) {
      if (!wait_ec) accept();
    });
  });
}

void ViewerServer::Impl::on_accepted(tcp::socket socket) {
  // At the cap, the connection that has waited longest without sending a request makes room (idle
  // connections must not keep a real request out); when every place holds a live request or a
  // WebSocket, the new connection is closed.
  if (open_connections >= max_connections && !close_idle_http()) {
    beast::error_code ec;
    socket.close(ec);
    return;
  }
  auto session = std::make_shared<HttpSession>(std::move(socket), *this);
  std::erase_if(http_sessions, [](const std::weak_ptr<HttpSession>& w) { return w.expired(); });
  http_sessions.push_back(session);
  session->start();
}

bool ViewerServer::Impl::close_idle_http() {
  std::shared_ptr<HttpSession> idlest;
  for (const auto& w : http_sessions) {
    auto s = w.lock();
    if (s && s->waiting_since() && (!idlest || *s->waiting_since() < *idlest->waiting_since())) idlest = std::move(s);
  }
  if (!idlest) return false;
  idlest->close_idle();
  return true;
}

std::vector<std::shared_ptr<WsSession>> ViewerServer::Impl::live_sessions() {
  std::lock_guard lock(mutex);
  std::vector<std::shared_ptr<WsSession>> live;
  std::erase_if(sessions, [&](const std::weak_ptr<WsSession>& w) {
    auto s = w.lock();
    if (!s) return true;
    live.push_back(std::move(s));
    return false;
  });
  return live;
}

void ViewerServer::Impl::check_files(const std::string& path, const nlohmann::json& value) const {
  const std::string key = owning_key(path);
  // the keys that name files: one name (or pattern), or a list of them (DICOM slices, series steps, trajectories)
  if (key == "file" || key == "files" || key == "trajectory" || key == "paraview") {
    const std::filesystem::path base = engine.base_dir().empty() ? std::filesystem::current_path() : std::filesystem::absolute(engine.base_dir());
    const auto root = std::filesystem::weakly_canonical(data_root);
    auto check = [&](const nlohmann::json& name) {
      if (!name.is_string()) return;  // not a file name: the scene reader refuses it
      const auto file = std::filesystem::weakly_canonical(base / name.get<std::string>());
      const auto rel = file.lexically_relative(root);
      if (rel.empty() || *rel.begin() == "..")
        throw Error(path + ": " + viewer_security::json_quoted(name.get<std::string>()) + " lies outside the data root (the viewer opens files only there)");
    };
    if (value.is_array())
      for (const auto& name : value) check(name);
    else
      check(value);
    if (!value.is_object()) return;
  }
  if (value.is_object())
    for (const auto& [k, v] : value.items()) check_files(path + "." + k, v);
  if (value.is_array())
    for (std::size_t i = 0; i < value.size(); ++i) check_files(path + "." + std::to_string(i), value[i]);
}

void ViewerServer::Impl::on_message(const std::shared_ptr<WsSession>& from, const std::string& text) {
  auto reply_error = [&](const std::string& message) { from->send_error(client_error(message)); };
  try {
    const nlohmann::json m = parse_json_text(text, "message");
    if (!m.is_object() || !m.contains("type") || !m["type"].is_string())
      throw Error("message: expected {\"type\": \"edit\" | \"resize\", ...}");
    const std::string type = m["type"];
    Job job;
    job.from = from;
    if (type == "edit") {
      if (!m.contains("set") || !m["set"].is_object() || m["set"].empty())
        throw Error("edit: expected \"set\": {\"PATH\": VALUE, ...} with at least one path");
      if (m.contains("preview")) {
        if (!m["preview"].is_boolean()) throw Error("edit: \"preview\" must be true or false");
        job.preview = m["preview"].get<bool>();
      }
      for (const auto& [path, value] : m["set"].items()) {
        viewer_security::check_no_control_characters(path, value);
        viewer_security::check_edit_limits(path, value);
        check_files(path, value);
        job.edits.emplace_back(path, value);
      }
    } else if (type == "resize") {
      for (const char* k : {"width", "height"})
        if (!m.contains(k) || !m[k].is_number_integer() || m[k].get<std::int64_t>() < 16 || m[k].get<std::int64_t>() > 4096)
          throw Error(std::string("resize: \"") + k + "\" must be an integer in [16, 4096]");
      job.edits = {{"camera.width", m["width"]}, {"camera.height", m["height"]}};
    } else {
      if (type != "probe") throw Error("message: unknown type \"" + type + "\" (expected edit, resize or probe)");
      const std::pair<float, float> pixel = probe_pixel(m);
      job.keeps_frame = true;
      job.task = [this, weak = std::weak_ptr<WsSession>(from), pixel] {
        if (auto s = weak.lock()) s->send_probe(std::make_shared<const std::string>(probe_message(engine.scene(), pixel.first, pixel.second).dump()));
      };
    }
    from->message_queued();
    queue(std::move(job));
  } catch (const std::exception& e) {
    reply_error(e.what());
  }
}

void ViewerServer::Impl::broadcast_state() {
  Text text;
  try {
    text = std::make_shared<const std::string>(state.message(engine).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra view: state failed: %s\n", e.what());
    return;
  }
  {
    std::lock_guard lock(mutex);
    last_state = text;
  }
  for (const auto& s : live_sessions()) s->send_state(text);
}

void ViewerServer::Impl::render_frame(Quality quality, bool accumulate) {
  Timer timer;
  FrameOptions frame_options{quality, accumulate, quality == Quality::Full ? &cancel : nullptr};
  frame_options.enlarge_preview = false;  // a preview travels at its reduced size; the page scales it
  const EngineFrame f = engine.render(frame_options);
  FrameMessage message = frame_message(f, quality, engine.scene(), timer.elapsed_ms(), options.max_samples);
  const auto jpeg = std::make_shared<const std::string>(std::move(message.jpeg));
  nlohmann::json& meta = message.meta;
  for (auto& r : meta["refinement"])  // a failed box read names its chunk: the data root never shown
    if (r.contains("error")) r["error"] = viewer_security::without_root(r["error"].get<std::string>(), data_root);
  Text meta_text;
  {
    std::lock_guard lock(mutex);
    meta["id"] = ++frame_id;
    meta_text = std::make_shared<const std::string>(meta.dump());
    last_frame_meta = meta_text;
    last_frame_jpeg = jpeg;
  }
  for (const auto& s : live_sessions()) s->send_frame(meta_text, jpeg);
}

void ViewerServer::Impl::render_loop() {
  bool need_preview = true, need_full = true;
  int samples = 0;
  broadcast_state();
  while (true) {
    std::deque<Job> batch;
    {
      std::unique_lock lock(mutex);
      wake.wait(lock, [&] { return stopping || !jobs.empty() || need_preview || need_full || samples < options.max_samples; });
      if (stopping) return;
      batch.swap(jobs);
      cancel = false;
    }
    bool edited = false, preview = false;
    for (Job& job : batch) {
      if (job.task) {
        job.task();
        if (!job.keeps_frame) {
          need_full = true;  // a screenshot renders sample 0 again
          samples = 0;
        }
      } else {
        try {
          engine.edit(job.edits);
          edited = true;
          preview = preview || job.preview;
        } catch (const std::exception& e) {
          if (job.from) job.from->send_error(client_error(e.what()));
        }
      }
      if (job.from) job.from->message_applied();  // a probe counts as a message as an edit does
    }
    if (edited) {
      broadcast_state();
      need_preview = need_preview || preview;  // a playback step waits for its full frame: no preview for it
      need_full = true;
      samples = 0;
    }
    {
      std::lock_guard lock(mutex);
      if (!jobs.empty()) continue;  // more input came: render for that
    }
    try {
      if (need_preview) {
        render_frame(Quality::Preview, false);
        need_preview = false;
      } else if (need_full) {
        render_frame(Quality::Full, true);
        need_full = false;
        samples = 1;
      } else if (samples < options.max_samples) {
        render_frame(Quality::Full, true);
        ++samples;
      }
    } catch (const Cancelled&) {
      // a newer edit made this frame stale; the loop takes it next
    } catch (const std::exception& e) {
      std::fprintf(stderr, "penumbra view: frame failed: %s\n", e.what());
      need_preview = need_full = false;
      samples = options.max_samples;
    }
  }
}

ViewerServer::ViewerServer(Engine engine, ViewerOptions options) : impl_(std::make_unique<Impl>(std::move(engine), std::move(options))) {
  Impl& s = *impl_;
  if (s.options.token.empty()) s.options.token = random_token();
  viewer_security::check_token(s.options.token);
  s.page = page_html(s.options.token);
  s.data_root = std::filesystem::absolute(s.options.data_root.empty() ? "." : s.options.data_root);
  if (!std::filesystem::is_directory(s.data_root)) throw Error("--data-root " + s.data_root.string() + ": not a directory");
  beast::error_code ec;
  const auto address = net::ip::make_address(s.options.host, ec);
  if (ec) throw Error("--host " + s.options.host + ": not an IP address (" + ec.message() + ")");
  const tcp::endpoint endpoint(address, s.options.port);
  s.acceptor.open(endpoint.protocol(), ec);
  if (!ec) s.acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(endpoint, ec);
  if (!ec) s.acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) throw Error("cannot listen on " + s.options.host + ":" + std::to_string(s.options.port) + ": " + ec.message());
  s.listener.host = s.options.host;
  s.listener.port = s.acceptor.local_endpoint().port();
  for (const std::string& origin : s.options.allow_origins) s.listener.allowed_origins.push_back(viewer_security::checked_origin_option(origin));
  for (const std::string& source : s.options.frame_ancestors)
    s.frame_ancestors += (s.frame_ancestors.empty() ? "" : " ") + viewer_security::checked_frame_ancestor(source);
  if (s.frame_ancestors.empty()) s.frame_ancestors = "'none'";
  s.max_connections = connection_cap(s.options.max_connections);
  // what edits may name is checked before they reach the engine (check_files); the files those files
  // name (an NRRD header's data file, a DICOM folder's slices) are checked by the loaders
  s.engine.confine_files_to(std::filesystem::weakly_canonical(s.data_root).string());
}

ViewerServer::~ViewerServer() { stop(); }

std::uint16_t ViewerServer::port() const { return impl_->acceptor.local_endpoint().port(); }
const std::string& ViewerServer::token() const { return impl_->options.token; }

bool ViewerServer::listens_on_all_interfaces() const { return impl_->acceptor.local_endpoint().address().is_unspecified(); }

std::string ViewerServer::url() const {
  // 0.0.0.0 and :: are no address to open: this machine's loopback of the same family is
  const auto address = impl_->acceptor.local_endpoint().address();
  std::string host = address.is_unspecified() ? (address.is_v4() ? "127.0.0.1" : "::1") : impl_->options.host;
  if (host.find(':') != std::string::npos) host = "[" + host + "]";
  return "http://" + host + ":" + std::to_string(port()) + "/?token=" + token();
}

void ViewerServer::run() {
  Impl& s = *impl_;
  net::signal_set signals(s.ioc);
  if (s.options.stop_on_signals) {
    signals.add(SIGINT);
    signals.add(SIGTERM);
    signals.async_wait([this](beast::error_code ec, int) {
      if (!ec) stop();
    });
  }
  s.accept();
  std::thread renderer([&s] { s.render_loop(); });
  while (true) {  // a handler's exception is logged; the server goes on serving the others
    try {
      s.ioc.run();
      break;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "penumbra view: %s\n", e.what());
    }
  }
  {
    std::lock_guard lock(s.mutex);
    s.stopping = true;
  }
  s.cancel = true;
  s.wake.notify_all();
  renderer.join();
  s.jobs.clear();  // the clients they hold go while the event loop they belong to still exists
  // Stopped means refused: the port is closed and every client disconnected now, not when the server
  // object goes (a Python Viewer lives on after stop()).
  beast::error_code ignored;
  s.acceptor.close(ignored);
  for (const auto& w : s.http_sessions)
    if (auto h = w.lock()) h->close_now();
  for (const auto& ws : s.live_sessions()) ws->close_now();
}

void ViewerServer::stop() {
  Impl& s = *impl_;
  {
    std::lock_guard lock(s.mutex);
    s.stopping = true;
  }
  s.cancel = true;
  s.wake.notify_all();
  s.ioc.stop();
}

}  // namespace penumbra
