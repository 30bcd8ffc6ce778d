// An initial state written from a simulated recording's truth (initial_state.hpp).

#include <algorithm>

#include "cdff/eval/initial_state.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"

namespace cdff::eval {

Result<WrittenInitialState> writeInitialState(const std::string& input, const std::string& output,
                                              const InitialStateFromRecording& o) {
  io::Replay replay;
  io::ReplayOptions replay_options;
  replay_options.channels = {o.truth_channel, o.at_channel};
  CDFF_RETURN_IF_ERROR(replay.open({input}, replay_options));
  std::vector<Transform> truth;
  std::optional<Timestamp> at;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    if (m.channel() == o.truth_channel) {
      Result<std::shared_ptr<const RigidBodyState>> s = m.decode<RigidBodyState>();
      if (!s) return s.status();
      truth.push_back((*s)->pose);
    } else if (!at) {
      at = m.logTime();
      // A scan's stamp is its start, earlier than its log time.
      if (m.type() == TypeId::of<PointCloud>()) {
        Result<std::shared_ptr<const PointCloud>> cloud = m.decode<PointCloud>();
        if (!cloud) return cloud.status();
        at = (*cloud)->stamp;
      }
    }
  }
  CDFF_RETURN_IF_ERROR(replay.status());
  if (!at) return notFound("{} has no message on '{}'", input, o.at_channel);
  std::sort(truth.begin(), truth.end(),
            [](const Transform& a, const Transform& b) { return a.stamp < b.stamp; });
  Result<RigidBodyState> state = perturbedInitialState(truth, *at, o.perturbation);
  if (!state) return state.status().withContext(input);
  io::Recorder recorder;
  CDFF_RETURN_IF_ERROR(recorder.open(output));
  CDFF_RETURN_IF_ERROR(recorder.write(o.channel, *state));
  CDFF_RETURN_IF_ERROR(recorder.close());
  return WrittenInitialState{*state, *at, truthAt(truth, *at, {})};
}

}  // namespace cdff::eval
