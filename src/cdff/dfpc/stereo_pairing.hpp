#pragma once
// Stereo pairs from two cameras' image channels: a recording (the simulator's, a test bench's)
// holds each camera's images on its own channel, and a stereo DFPC takes StereoImagePair. The
// pairing stream passes every message of its input through and, after the second image of an
// instant (the left and the right image with the same stamp), adds the pair on its own channel,
// with right_T_left from the two cameras' mountings in the same input (Transforms whose child
// frames are the images' frames and whose parents agree: /chaser/tf/camera_left_optical...).
//
//   StereoPairing pairing{"/chaser/stereo/pair", "/chaser/camera/left/image",
//                         "/chaser/camera/right/image"};
//   StereoPairStream input(recording, {pairing});   // reads `recording`
//
// An image whose partner does not come is not paired (a dropped frame); an image that comes
// before both mountings are known, or images whose frames' mountings have different parents,
// stop the stream with an error naming the channel, the frame and what was expected.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cdff/dfpc/stream.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"

namespace cdff::dfpc {

struct StereoPairing {
  std::string channel;  // where the pairs go
  std::string left;     // the left camera's image channel
  std::string right;    // the right camera's image channel
};

/// Parses "CHANNEL=LEFT,RIGHT"
/// ("/chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image").
Result<StereoPairing> parseStereoPairing(const std::string& text);

class StereoPairStream final : public InputStream {
 public:
  /// Reads `input`, which must outlive the stream.
  StereoPairStream(InputStream& input, std::vector<StereoPairing> pairings);

  Result<std::optional<Message>> next() override;
  /// The input's channels, and each pairing's channel (as many pairs as the fewer images).
  std::vector<ChannelInfo> channels() const override;
  std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override;

 private:
  struct Pending {
    std::optional<Image> left, right;
  };
  Result<std::optional<Message>> pair(std::size_t pairing, const Image& image, bool left);

  InputStream& input_;
  std::vector<StereoPairing> pairings_;
  std::vector<Pending> pending_;                // per pairing
  std::map<std::string, Transform> mountings_;  // by child frame, the latest
  std::optional<Message> queued_;               // a pair to deliver after its second image
};

}  // namespace cdff::dfpc
