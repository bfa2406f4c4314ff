#include "penumbra/viewer/client_queue.h"

namespace penumbra {

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
