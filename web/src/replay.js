// The replay page's stream: one WebSocket per choice of recording and channels; images arrive
// as binary frames, poses and the replay's state as JSON (docs/web-ui.md#the-replay-stream).
import { openSocket, splitFrame } from './api.js';

// Points of a LIDAR scan sent at most (the server thins the scan to this bound).
const MAX_POINTS = 20000;

export class ReplayStream {
  /**
   * `pose`: a channel or a list; `points`: a PointCloud channel. `handlers`: onImage(header,
   * blob), onPoints(header, buffer, offset), onPose(frame), onState(state), onError(message).
   */
  constructor(recordingId, { image, pose, points }, handlers) {
    this.handlers = handlers;
    this.socket = openSocket(`/api/recordings/${recordingId}/stream`,
                             { image, pose, points, max_width: 640, max_points: points ? MAX_POINTS : undefined });
    this.pending = [];
    this.socket.addEventListener('open', () => {
      for (const c of this.pending) this.socket.send(JSON.stringify(c));
      this.pending = [];
    });
    this.socket.addEventListener('message', (event) => this.receive(event.data));
    this.socket.addEventListener('close', (event) => {
      if (!this.closing && event.code !== 1000) {
        handlers.onError(`the replay stream closed (${event.code}${event.reason ? `: ${event.reason}` : ''})`);
      }
    });
  }

  receive(data) {
    if (typeof data !== 'string') {
      const { header, payload } = splitFrame(data);
      if (header.type === 'points') this.handlers.onPoints(header, data, payload.byteOffset);
      else this.handlers.onImage(header, new Blob([payload], { type: 'image/jpeg' }));
      return;
    }
    const frame = JSON.parse(data);
    if (frame.type === 'pose') this.handlers.onPose(frame);
    else if (frame.type === 'state') this.handlers.onState(frame);
    else if (frame.type === 'error') this.handlers.onError(frame.error);
  }

  /** play | pause | seek (t: seconds) | speed (value: factor) */
  send(command) {
    if (this.socket.readyState === WebSocket.OPEN) this.socket.send(JSON.stringify(command));
    else this.pending.push(command);
  }

  close() {
    this.closing = true;
    this.socket.close(1000);
  }
}
