// The ground-station web application (docs/web-ui.md): the Replay and Live pages.
import './style.css';
import { getJson } from './api.js';
import { LivePage } from './live.js';
import { PositionPlot } from './plot.js';
import { ReplayStream } from './replay.js';

const $ = (id) => document.getElementById(id);
const POSE_TYPES = ['PoseWithCovariance', 'RigidBodyState', 'Transform'];

const state = {
  recording: null,  // the summary with channels
  stream: null,
  playing: false,
  ended: false,
  scrubbing: false,
  imageUrl: null,
};
const plot = new PositionPlot($('plot'));

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
    $('frame-caption').textContent = `${header.channel}: frame at ${header.t.toFixed(3)} s `
      + `(${header.source_width}×${header.source_height}, shown at ${header.width}×${header.height})`;
    if (state.playing) showTime(header.t);
  },
  onPose(frame) {
    if (state.playing) showTime(frame.t);
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
  if (!image && !pose) return;
  state.stream = new ReplayStream(state.recording.id, { image, pose }, handlers);
  state.stream.send({ cmd: 'speed', value: Number($('speed').value) });
  if (pose) {
    plot.show(pose, await getJson(`/api/recordings/${state.recording.id}/poses`,
                                  { channel: pose, max_points: 4000 }));
  } else {
    plot.clear();
  }
}

async function selectRecording(id) {
  state.recording = await getJson(`/api/recordings/${id}`);
  for (const li of $('recordings').children) li.classList.toggle('active', li.dataset.id === String(id));
  renderChannels(state.recording);
  const withMessages = state.recording.channels.filter((c) => c.messages > 0);
  fillSelect($('image-channel'), withMessages.filter((c) => c.type === 'Image'), /camera\/left\/image$/);
  fillSelect($('pose-channel'), withMessages.filter((c) => POSE_TYPES.includes(c.type)), /^\/truth\/target_pose$/);
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
