// The ground-station web application (docs/web-ui.md): the Replay and Live pages.
import './style.css';
import { getJson } from './api.js';
import { ErrorPlot } from './errorplot.js';
import { LivePage } from './live.js';
import { LvlhPlot, PositionPlot } from './plot.js';
import { ReplayStream } from './replay.js';
import { ContourOverlay } from './overlay.js';
import { SceneView, recordingScene } from './scene.js';

const $ = (id) => document.getElementById(id);
const POSE_TYPES = ['PoseWithCovariance', 'RigidBodyState', 'Transform'];

const state = {
  recording: null,  // the summary with channels
  stream: null,
  playing: false,
  ended: false,
  scrubbing: false,
  imageUrl: null,
  frames: {},  // pose channel -> {frame, child_frame}
  estimate: '',  // the 3D view's estimate and truth channels
  truth: '',
};
const plot = new PositionPlot($('plot'));
const scene = new SceneView($('scene'), $('scene-caption'));
const errorPlot = new ErrorPlot($('error-plot'));
const lvlhPlot = new LvlhPlot($('lvlh-plot'));
const overlay = new ContourOverlay($('frame'), $('frame-overlay'));

// The contour of the model at the estimate's pose (or the truth's) over the image shown: one
// request at a time, the latest image's when several came meanwhile.
const contour = { busy: false, next: null };
async function requestContour(image) {
  const pose = state.estimate || state.truth;
  if (!pose || !state.hasMesh) {
    overlay.clear();
    return;
  }
  if (contour.busy) {
    contour.next = image;
    return;
  }
  contour.busy = true;
  try {
    const c = await getJson(`/api/recordings/${state.recording.id}/contour`, { image: image.channel, t: image.t, pose });
    overlay.show(c, c.source_width, c.source_height, `model at ${pose}`);
  } catch (e) {
    overlay.clear();
    $('frame-caption').textContent += ` — no contour: ${e.message}`;
  } finally {
    contour.busy = false;
    const next = contour.next;
    contour.next = null;
    if (next) requestContour(next);
  }
}

// A pose channel's frames (from its first pose).
async function framesOf(channel) {
  if (!state.frames[channel]) {
    const p = await getJson(`/api/recordings/${state.recording.id}/poses`, { channel, max_points: 2 });
    state.frames[channel] = { frame: p.frame, child_frame: p.child_frame };
  }
  return state.frames[channel];
}

function showError(message) {
  $('status').textContent = message;
  $('status').className = 'error';
}

function showTime(t) {
  $('time').textContent = `${t.toFixed(3)} s`;
  if (!state.scrubbing) $('scrub').value = String(t);
  plot.setTime(t);
}

function fillSelect(select, channels, preferred) {
  select.replaceChildren(...channels.map((c) => new Option(c.topic, c.topic)));
  const pick = channels.find((c) => preferred.test(c.topic)) ?? channels[0];
  if (pick) select.value = pick.topic;
  select.disabled = channels.length === 0;
}

function renderChannels(recording) {
  // A topic may wrap after its slashes only.
  const breakable = (topic) => topic.split('/').flatMap((part, i) => (
    i === 0 ? [part] : [document.createElement('wbr'), `/${part}`]));
  const rows = recording.channels.map((c) => {
    const tr = document.createElement('tr');
    for (const content of [breakable(c.topic), [c.type || c.schema || '-'], [String(c.messages)],
                           [c.rate_hz > 0 ? `${c.rate_hz.toFixed(2)} Hz` : '-']]) {
      const td = document.createElement('td');
      td.append(...content);
      tr.append(td);
    }
    tr.dataset.topic = c.topic;
    return tr;
  });
  $('channels').tBodies[0].replaceChildren(...rows);
}

const handlers = {
  onImage(header, blob) {
    const img = $('frame');
    const previous = state.imageUrl;
    state.imageUrl = URL.createObjectURL(blob);
    img.src = state.imageUrl;
    if (previous) URL.revokeObjectURL(previous);
    img.dataset.t = header.t.toFixed(6);
    img.dataset.channel = header.channel;
    img.dataset.logTimeNs = String(header.log_time_ns);
    requestContour(header);
    $('frame-caption').textContent = `${header.channel}: frame at ${header.t.toFixed(3)} s `
      + `(${header.source_width}×${header.source_height}, shown at ${header.width}×${header.height})`;
    if (state.playing) showTime(header.t);
  },
  onPose(frame) {
    if (state.playing) showTime(frame.t);
    const pose = { ...frame, ...state.frames[frame.channel], source: frame.channel };
    if (frame.channel === state.estimate) scene.setEstimate(pose);
    if (frame.channel === state.truth) scene.setTruth(pose);
  },
  onPoints(header, buffer, offset) {
    scene.setPoints(header, buffer, offset);
  },
  onState(s) {
    state.playing = s.playing;
    state.ended = s.ended;
    $('play').textContent = s.playing ? 'Pause' : 'Play';
    document.body.dataset.position = s.t.toFixed(6);
    showTime(s.t);
    if (s.dropped > 0) $('status').textContent = `${s.dropped} frame(s) dropped for this browser`;
  },
  onError: showError,
};

async function openStream() {
  state.stream?.close();
  state.stream = null;
  state.playing = false;
  $('play').textContent = 'Play';
  const image = $('image-channel').value;
  const pose = $('pose-channel').value;
  const points = $('points-channel').value;
  await chooseEstimate($('estimate-channel').value);
  const poses = [...new Set([pose, state.estimate, state.truth].filter(Boolean))];
  if (!image && poses.length === 0 && !points) return;
  state.stream = new ReplayStream(state.recording.id, { image, pose: poses, points }, handlers);
  state.stream.send({ cmd: 'speed', value: Number($('speed').value) });
  if (pose) {
    const poses = await getJson(`/api/recordings/${state.recording.id}/poses`, { channel: pose, max_points: 4000 });
    // The estimate beside the channel when both are the same transform (truth against estimate).
    const e = state.estimateTrack;
    const same = e && pose !== state.estimate && e.frame === poses.frame && e.child_frame === poses.child_frame;
    plot.show(pose, poses, same ? { channel: state.estimate, poses: e } : null);
  } else {
    plot.clear();
  }
}

// The 3D view's estimate (a /cdff/ pose product, or none) and its truth (the /truth/ pose channel
// of the same frames, /truth/target_pose first; without an estimate, /truth/target_pose); the
// error plot of the estimate against it, as `cdff eval` measures it.
async function chooseEstimate(estimate) {
  const truths = state.recording.channels.filter((c) => c.topic.startsWith('/truth/') && POSE_TYPES.includes(c.type) && c.messages > 0)
    .sort((a, b) => (b.topic === '/truth/target_pose') - (a.topic === '/truth/target_pose'));
  state.estimate = estimate;
  state.truth = '';
  if (estimate) {
    const want = await framesOf(estimate);
    for (const c of truths) {
      const f = await framesOf(c.topic);
      if (f.frame === want.frame && f.child_frame === want.child_frame) {
        state.truth = c.topic;
        break;
      }
    }
  } else if (truths.some((c) => c.topic === '/truth/target_pose')) {
    state.truth = '/truth/target_pose';
    await framesOf(state.truth);
  }
  scene.setEstimate(null);
  scene.setTruth(null);
  // The trajectories, truth and estimate, in 3D.
  const track = (channel) => (channel
    ? getJson(`/api/recordings/${state.recording.id}/poses`, { channel, max_points: 4000 }) : null);
  const [truthTrack, estimateTrack] = await Promise.all([track(state.truth), track(estimate)]);
  scene.setTrack('truth', truthTrack);
  scene.setTrack('estimate', estimateTrack);
  state.estimateTrack = estimateTrack;
  await showLvlh(estimate, estimateTrack);
  if (!estimate) {
    errorPlot.clear('No estimate chosen: the recording of a run (cdff run ... -o OUT.mcap) has the DFPCs\' pose products.');
    return;
  }
  try {
    const errors = await getJson(`/api/recordings/${state.recording.id}/errors`, { estimate, max_points: 4000 });
    errorPlot.show(errors, `${estimate} against ${errors.truth} (${errors.child_frame} in ${errors.frame}): error and requirement thresholds`);
  } catch (e) {
    errorPlot.clear(e.message);
  }
}

// The chaser's and the target's true trajectories in LVLH (the simulator's /truth/tf/servicer and
// /truth/tf/target), and the estimate through the chaser's when it is relative to the servicer.
async function showLvlh(estimate, estimateTrack) {
  const has = (topic) => state.recording.channels.some((c) => c.topic === topic && c.messages > 0);
  const get = (params) => getJson(`/api/recordings/${state.recording.id}/poses`, { max_points: 4000, ...params });
  const chaser = has('/truth/tf/servicer') ? await get({ channel: '/truth/tf/servicer' }) : null;
  const target = has('/truth/tf/target') ? await get({ channel: '/truth/tf/target' }) : null;
  const relative = estimateTrack && chaser && estimateTrack.frame === chaser.child_frame;
  const through = relative ? await get({ channel: estimate, via: '/truth/tf/servicer' }) : null;
  lvlhPlot.show(chaser, target, through, { chaser: 'chaser', target: 'target truth', estimate: 'target estimate' });
}

async function selectRecording(id) {
  state.recording = await getJson(`/api/recordings/${id}`);
  for (const li of $('recordings').children) li.classList.toggle('active', li.dataset.id === String(id));
  renderChannels(state.recording);
  const withMessages = state.recording.channels.filter((c) => c.messages > 0);
  fillSelect($('image-channel'), withMessages.filter((c) => c.type === 'Image'), /camera\/left\/image$/);
  fillSelect($('pose-channel'), withMessages.filter((c) => POSE_TYPES.includes(c.type)), /^\/truth\/target_pose$/);
  fillSelect($('points-channel'), withMessages.filter((c) => c.type === 'PointCloud'), /^\/chaser\/lidar\/points$/);
  const estimates = withMessages.filter((c) => POSE_TYPES.includes(c.type) && c.topic.startsWith('/cdff/'));
  fillSelect($('estimate-channel'), estimates, /\/(pose|state)$/);
  $('estimate-channel').prepend(new Option('none', ''));
  if (estimates.length === 0) $('estimate-channel').value = '';
  $('estimate-channel').disabled = estimates.length === 0;
  state.frames = {};
  const resources = await recordingScene(state.recording);
  scene.setMountings(resources.mountings);
  if (resources.mesh) scene.setModel(resources.mesh.geometry, resources.meshChannel);
  state.hasMesh = Boolean(resources.mesh);
  $('scrub').max = String(state.recording.duration_s);
  showTime(0);
  await openStream();
}

function bindControls() {
  $('play').addEventListener('click', () => {
    if (!state.stream) return;
    if (state.playing) {
      state.stream.send({ cmd: 'pause' });
    } else {
      if (state.ended) state.stream.send({ cmd: 'seek', t: 0 });
      state.stream.send({ cmd: 'play' });
    }
  });
  const scrub = $('scrub');
  scrub.addEventListener('pointerdown', () => { state.scrubbing = true; });
  scrub.addEventListener('pointerup', () => { state.scrubbing = false; });
  scrub.addEventListener('input', () => {
    const t = Number(scrub.value);
    $('time').textContent = `${t.toFixed(3)} s`;
    plot.setTime(t);
    state.stream?.send({ cmd: 'seek', t });
  });
  $('speed').addEventListener('change', () => {
    state.stream?.send({ cmd: 'speed', value: Number($('speed').value) });
  });
  $('image-channel').addEventListener('change', () => openStream().catch((e) => showError(e.message)));
  $('pose-channel').addEventListener('change', () => openStream().catch((e) => showError(e.message)));
  $('points-channel').addEventListener('change', () => openStream().catch((e) => showError(e.message)));
  $('estimate-channel').addEventListener('change', () => openStream().catch((e) => showError(e.message)));
}

// The page named by the URL's #hash (Replay by default); the Live page connects when first shown.
const live = new LivePage();
function showPage() {
  const page = window.location.hash === '#live' ? 'live' : 'replay';
  for (const name of ['replay', 'live']) {
    $(name).hidden = name !== page;
    $(`tab-${name}`).classList.toggle('active', name === page);
  }
  if (page === 'live') live.open().catch((e) => { $('live-error').textContent = e.message; });
}

async function main() {
  window.addEventListener('hashchange', showPage);
  showPage();
  bindControls();
  const recordings = await getJson('/api/recordings');
  $('recordings').replaceChildren(...recordings.map((r) => {
    const li = document.createElement('li');
    li.dataset.id = String(r.id);
    li.textContent = `${r.name} (${r.duration_s.toFixed(1)} s, ${r.messages} messages)`;
    li.addEventListener('click', () => selectRecording(r.id).catch((e) => showError(e.message)));
    return li;
  }));
  if (recordings.length === 0) {
    showError('no recording: start `cdff serve RECORDING.mcap ...`');
    return;
  }
  await selectRecording(recordings[0].id);
  document.body.dataset.ready = 'true';
}

main().catch((e) => showError(e.message));
