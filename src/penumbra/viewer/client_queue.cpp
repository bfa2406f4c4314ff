#include "penumbra/viewer/client_queue.h"

#include <nlohmann/json.hpp>

#include <algorithm>

namespace penumbra {

namespace {

// `newer`'s header with the edits and rebuilds of `older`, a frame it replaces unsent, in front of its
// own (each once); `newer` itself when `older` reported neither.
ClientQueue::Text with_reports_of(const std::string& older, ClientQueue::Text newer) {
  const nlohmann::json old_meta = nlohmann::json::parse(older);
  auto reported = [&](const char* key) { return old_meta.contains(key) && !old_meta[key].empty(); };
  if (!reported("edits") && !reported("rebuilt")) return newer;
  nlohmann::json meta = nlohmann::json::parse(*newer);
  for (const char* key : {"edits", "rebuilt"}) {
    if (!reported(key)) continue;
    nlohmann::json merged = old_meta[key];
    for (const auto& item : meta.value(key, nlohmann::json::array()))
      if (std::find(merged.begin(), merged.end(), item) == merged.end()) merged.push_back(item);
    meta[key] = std::move(merged);
  }
  return std::make_shared<const std::string>(meta.dump());
}

}  // namespace

void ClientQueue::push_frame(Text meta, Text jpeg) {
  if (frame_) meta = with_reports_of(*frame_->meta, std::move(meta));
  frame_ = Frame{std::move(meta), std::move(jpeg)};
}

void ClientQueue::push_error(Text error) {
  if (errors_.size() == kMaxErrors) errors_.pop_front();
  errors_.push_back(Message{std::move(error), false});
}

const ClientQueue::Message* ClientQueue::start_next() {
  if (in_flight_) return nullptr;
  if (jpeg_after_header_) {
    in_flight_ = Message{std::move(jpeg_after_header_), true};
    jpeg_after_header_.reset();
  } else if (!errors_.empty()) {
    in_flight_ = std::move(errors_.front());
    errors_.pop_front();
  } else if (state_) {  // before the frame: a frame after an edit shows the state the page should show
    in_flight_ = std::move(state_);
    state_.reset();
  } else if (probe_) {
    in_flight_ = std::move(probe_);
    probe_.reset();
  } else if (frame_) {
    in_flight_ = Message{std::move(frame_->meta), false};
    jpeg_after_header_ = std::move(frame_->jpeg);
    frame_.reset();
  } else {
    return nullptr;
  }
  return &*in_flight_;
}

void ClientQueue::clear() {
  in_flight_.reset();
  jpeg_after_header_.reset();
  errors_.clear();
  state_.reset();
  probe_.reset();
  frame_.reset();
}

}  // namespace penumbra
