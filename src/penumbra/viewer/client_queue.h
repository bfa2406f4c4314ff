// What waits to be sent to one WebSocket client of the viewer, bounded whatever the client's pace.
// A client that reads slowly, or not at all, must not make the server's memory grow: of the state and
// of the frame only the latest waits (a newer one replaces the older, which nobody needs any more),
// as of the answers to probes (the value under the pointer: only the latest pointer matters), and of
// error replies at most kMaxErrors (the oldest are dropped). So at most one message in flight, one
// state, one frame (header and JPEG), one probe answer and kMaxErrors errors are held per client.
// A frame replaced before it went passes on what only it reported: the paths edited since the frame
// before ("edits") and what they rebuilt ("rebuilt") are merged into the newer frame's header, so a
// client learns of every edit's first frame and its rebuilds even when it reads too slowly to see it.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <optional>
#include <string>

namespace penumbra {

class ClientQueue {
public:
  using Text = std::shared_ptr<const std::string>;
  struct Message {
    Text data;
    bool binary = false;
  };
  static constexpr std::size_t kMaxErrors = 16;

  void push_state(Text state) { state_ = Message{std::move(state), false}; }
  // `meta` is the frame's JSON header (docs/viewer.md, the "frame" message).
  void push_frame(Text meta, Text jpeg);
  void push_error(Text error);
  void push_probe(Text answer) { probe_ = Message{std::move(answer), false}; }

  // The message to write now, which stays in flight until written(); null when one is already in
  // flight or nothing waits. A frame's JPEG follows its header before anything else.
  const Message* start_next();
  void written() { in_flight_.reset(); }
  bool idle() const { return !in_flight_; }
  // Forgets everything (the client went away).
  void clear();

private:
  struct Frame {
    Text meta, jpeg;
  };
  std::optional<Message> in_flight_;
  Text jpeg_after_header_;  // the JPEG of the frame whose header is in flight (or just went)
  std::deque<Message> errors_;
  std::optional<Message> state_;
  std::optional<Message> probe_;
  std::optional<Frame> frame_;
};

}  // namespace penumbra
