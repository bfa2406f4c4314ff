// The viewer's per-client queue (src/penumbra/viewer/client_queue.h): bounded whatever the client's
// pace, and a frame replaced unsent passes on the edits and rebuilds only it reported.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>

#include "penumbra/viewer/client_queue.h"

namespace penumbra {
namespace {

ClientQueue::Text text(const nlohmann::json& j) { return std::make_shared<const std::string>(j.dump()); }
ClientQueue::Text bytes(const char* jpeg) { return std::make_shared<const std::string>(jpeg); }

nlohmann::json frame(int id, nlohmann::json edits, nlohmann::json rebuilt) {
  return {{"type", "frame"}, {"id", id}, {"edits", std::move(edits)}, {"rebuilt", std::move(rebuilt)}};
}

// Everything the queue has to write now, in order (each written at once, as by a fast socket).
std::vector<ClientQueue::Message> drain(ClientQueue& queue) {
  std::vector<ClientQueue::Message> out;
  while (const ClientQueue::Message* m = queue.start_next()) {
    out.push_back(*m);
    queue.written();
  }
  return out;
}

TEST(ClientQueue, AFrameReplacedUnsentPassesOnItsEditsAndRebuilds) {
  ClientQueue queue;
  const nlohmann::json rebuilt_light = {{"structure", "lights.0.shadows"}, {"cause", "lights.0.direction"}};
  const nlohmann::json rebuilt_tf = {{"structure", "volumes.0.classification"}, {"cause", "volumes.0.transfer_function"}};
  queue.push_frame(text(frame(1, {"lights.0.direction"}, {rebuilt_light})), bytes("jpeg 1"));
  queue.push_frame(text(frame(2, nlohmann::json::array(), nlohmann::json::array())), bytes("jpeg 2"));
  queue.push_frame(text(frame(3, {"volumes.0.transfer_function", "lights.0.direction"}, {rebuilt_tf})), bytes("jpeg 3"));
  const auto sent = drain(queue);
  ASSERT_EQ(sent.size(), 2u);  // only the latest frame: its header, then its JPEG
  const nlohmann::json meta = nlohmann::json::parse(*sent[0].data);
  EXPECT_FALSE(sent[0].binary);
  EXPECT_EQ(meta["id"], 3);
  EXPECT_EQ(meta["edits"], nlohmann::json({"lights.0.direction", "volumes.0.transfer_function"}));
  EXPECT_EQ(meta["rebuilt"], nlohmann::json({rebuilt_light, rebuilt_tf}));
  EXPECT_TRUE(sent[1].binary);
  EXPECT_EQ(*sent[1].data, "jpeg 3");
}

TEST(ClientQueue, AFrameSentIsNotReportedAgain) {
  ClientQueue queue;
  queue.push_frame(text(frame(1, {"camera.fov_deg"}, nlohmann::json::array())), bytes("jpeg 1"));
  ASSERT_EQ(drain(queue).size(), 2u);
  const auto plain = text(frame(2, nlohmann::json::array(), nlohmann::json::array()));
  queue.push_frame(plain, bytes("jpeg 2"));
  const auto sent = drain(queue);
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[0].data, plain);  // the very header the server made: nothing merged, nothing copied
}

TEST(ClientQueue, WhatWaitsStaysBoundedWhateverTheClientsPace) {
  ClientQueue queue;
  for (int i = 0; i < 1000; ++i) {
    queue.push_state(text({{"type", "state"}, {"n", i}}));
    queue.push_probe(text({{"type", "probe"}, {"n", i}}));
    queue.push_error(text({{"type", "error"}, {"n", i}}));
    queue.push_frame(text(frame(i, {"camera.position"}, nlohmann::json::array())), bytes("jpeg"));
  }
  const auto sent = drain(queue);
  // the latest kMaxErrors errors, then the latest state, probe answer and frame (header and JPEG)
  ASSERT_EQ(sent.size(), ClientQueue::kMaxErrors + 4);
  EXPECT_EQ(nlohmann::json::parse(*sent.front().data)["n"], 1000 - static_cast<int>(ClientQueue::kMaxErrors));
  EXPECT_EQ(nlohmann::json::parse(*sent[ClientQueue::kMaxErrors].data)["type"], "state");
  const nlohmann::json last = nlohmann::json::parse(*sent[ClientQueue::kMaxErrors + 2].data);
  EXPECT_EQ(last["id"], 999);
  EXPECT_EQ(last["edits"], nlohmann::json({"camera.position"}));  // the same path merged once, not a thousand times
}

}  // namespace
}  // namespace penumbra
