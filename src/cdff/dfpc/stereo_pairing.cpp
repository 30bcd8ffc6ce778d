#include "cdff/dfpc/stereo_pairing.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace cdff::dfpc {

Result<StereoPairing> parseStereoPairing(const std::string& text) {
  const std::size_t eq = text.find('=');
  const std::size_t comma = text.find(',', eq == std::string::npos ? 0 : eq);
  StereoPairing p;
  if (eq != std::string::npos && comma != std::string::npos) {
    p.channel = text.substr(0, eq);
    p.left = text.substr(eq + 1, comma - eq - 1);
    p.right = text.substr(comma + 1);
  }
  if (p.channel.empty() || p.left.empty() || p.right.empty() || p.left == p.right)
    return invalidParameter(
        "stereo pairing '{}': expected CHANNEL=LEFT,RIGHT with two different image channels "
        "(e.g. /chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image)",
        text);
  return p;
}

StereoPairStream::StereoPairStream(InputStream& input, std::vector<StereoPairing> pairings)
    : input_(input), pairings_(std::move(pairings)), pending_(pairings_.size()) {}

std::vector<ChannelInfo> StereoPairStream::channels() const {
  std::vector<ChannelInfo> out = input_.channels();
  for (const StereoPairing& p : pairings_) {
    std::uint64_t left = 0, right = 0;
    for (const ChannelInfo& c : out) {
      if (c.channel == p.left) left = c.message_count;
      if (c.channel == p.right) right = c.message_count;
    }
    out.push_back({p.channel, findType("StereoImagePair"), std::min(left, right)});
  }
  return out;
}

std::optional<std::pair<Timestamp, Timestamp>> StereoPairStream::timeRange() const {
  return input_.timeRange();
}

Result<std::optional<Message>> StereoPairStream::next() {
  if (queued_) {
    std::optional<Message> out = std::move(queued_);
    queued_.reset();
    return out;
  }
  Result<std::optional<Message>> next = input_.next();
  if (!next || !next.value()) return next;
  const Message& m = *next.value();
  if (const Transform* t = m.as<Transform>()) mountings_[t->child_frame] = *t;
  if (const Image* image = m.as<Image>()) {
    for (std::size_t i = 0; i < pairings_.size(); ++i) {
      const bool left = m.channel == pairings_[i].left;
      if (!left && m.channel != pairings_[i].right) continue;
      Result<std::optional<Message>> pair = this->pair(i, *image, left);
      if (!pair) return pair.status();
      if (pair.value()) queued_ = std::move(pair).value();
    }
  }
  return next;
}

Result<std::optional<Message>> StereoPairStream::pair(std::size_t index, const Image& image,
                                                      bool left) {
  const StereoPairing& p = pairings_[index];
  Pending& pending = pending_[index];
  // An image of another instant than the one waiting: that one's partner was dropped.
  std::optional<Image>& other = left ? pending.right : pending.left;
  if (other && other->stamp != image.stamp) other.reset();
  (left ? pending.left : pending.right) = image;
  if (!pending.left || !pending.right) return std::optional<Message>();
  const auto mounting = [&](const Image& i, const std::string& channel) -> Result<Transform> {
    auto it = mountings_.find(i.frame_id);
    if (it == mountings_.end())
      return notFound(
          "stereo pairing '{}': no mounting of frame '{}' (the images of '{}') before its image "
          "at t = {} us; expected a Transform whose child frame is '{}' (/chaser/tf/{})",
          p.channel, i.frame_id, channel, i.stamp, i.frame_id, i.frame_id);
    return it->second;
  };
  Result<Transform> l = mounting(*pending.left, p.left);
  if (!l) return l.status();
  Result<Transform> r = mounting(*pending.right, p.right);
  if (!r) return r.status();
  // right_T_left = (servicer_T_right)^-1 * servicer_T_left; compose checks the common frame.
  Result<Transform> right_T_left = r->inverse().compose(*l);
  if (!right_T_left)
    return right_T_left.status().withContext(
        fmt::format("stereo pairing '{}': the cameras' mountings", p.channel));
  StereoImagePair pair;
  pair.left = std::move(*pending.left);
  pair.right = std::move(*pending.right);
  pending.left.reset();
  pending.right.reset();
  pair.right_T_left = std::move(right_T_left).value();
  pair.right_T_left.stamp = pair.left.stamp;
  const Timestamp stamp = pair.left.stamp;
  return std::optional<Message>(Message::of(p.channel, stamp, std::move(pair)));
}

}  // namespace cdff::dfpc
