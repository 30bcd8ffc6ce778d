// The Live page (docs/web-ui.md#the-live-run): a DFPC graph run on a served recording through
// the server's /api/live routes (the §7.3 external API: setCDFFState, initDFPC, stopDFPC),
// watched over /ws/live: the camera image
// being processed, the estimated position against the truth, each DFPC's state and faults, the
// events log.
import uPlot from 'uplot';
import { getBinary, getJson, sendJson, openSocket, splitFrame } from './api.js';
import { ErrorPlot } from './errorplot.js';
import { ContourOverlay } from './overlay.js';
import { SceneView, meshGeometry, recordingScene } from './scene.js';

const $ = (id) => document.getElementById(id);
const POSE_TYPES = ['PoseWithCovariance', 'RigidBodyState', 'Transform'];
const AXES = ['x', 'y', 'z'];
const COLOURS = ['#c0392b', '#27ae60', '#2980b9'];
const MAX_EVENTS = 200;

// The estimated position (solid) against the truth (dashed), x, y, z against time.
class LivePlot {
  constructor(element) {
    this.element = element;
    this.plot = null;
    this.truth = null;  // {t, x, y, z}
    this.estimate = { t: [], x: [], y: [], z: [] };
    this.title = '';
    this.pending = false;
  }

  /** A new run: no estimate yet, no truth until setTruth(). */
  reset(title) {
    this.estimate = { t: [], x: [], y: [], z: [] };
    this.setTruth(null, title);
  }

  /** The truth of the run's recording (the estimates received meanwhile are kept). */
  setTruth(truth, title) {
    this.truth = truth;
    this.title = title;
    this.plot?.destroy();
    this.plot = null;
    this.element.dataset.truth = String(truth?.t.length ?? 0);
    this.draw();
  }

  add(frame) {
    const e = this.estimate;
    if (e.t.length && frame.t <= e.t.at(-1)) return;
    e.t.push(frame.t);
    AXES.forEach((axis, i) => e[axis].push(frame.p[i]));
    if (!this.pending) {  // at most one redraw per animation frame
      this.pending = true;
      requestAnimationFrame(() => { this.pending = false; this.draw(); });
    }
  }

  data() {
    const tables = [[this.estimate.t, this.estimate.x, this.estimate.y, this.estimate.z]];
    if (this.truth) tables.push([this.truth.t, this.truth.x, this.truth.y, this.truth.z]);
    if (tables.every((t) => t[0].length === 0)) return [[], [], [], [], ...(this.truth ? [[], [], []] : [])];
    return uPlot.join(tables);
  }

  draw() {
    const data = this.data();
    if (!this.plot) {
      const series = [{ label: 't (s)' }];
      AXES.forEach((axis, i) => series.push({ label: `${axis} estimate`, stroke: COLOURS[i], width: 2, spanGaps: true }));
      if (this.truth) {
        AXES.forEach((axis, i) => series.push({ label: `${axis} truth`, stroke: COLOURS[i], dash: [6, 4], width: 1, spanGaps: true }));
      }
      this.plot = new uPlot({
        title: this.title,
        width: Math.max(320, this.element.clientWidth),
        height: 260,
        scales: { x: { time: false } },
        axes: [{ label: 't (s)' }, { label: 'm' }],
        series,
      }, data, this.element);
    } else {
      this.plot.setData(data);
    }
    this.element.dataset.estimates = String(this.estimate.t.length);
  }
}

export class LivePage {
  constructor() {
    this.plot = new LivePlot($('live-plot'));
    this.scene = new SceneView($('live-scene'), $('live-scene-caption'));
    this.errors = new ErrorPlot($('live-error-plot'));
    this.overlay = new ContourOverlay($('live-frame'), $('live-frame-overlay'));
    this.socket = null;
    this.run = null;  // the server's state of the run
    this.runKey = '';  // the number of the run the plot shows
    this.truthFor = '';  // the run whose truth and events are shown
    this.imageUrl = null;
    this.recordings = [];
  }

  async open() {
    if (this.socket) return;
    const [graphs, recordings] = await Promise.all([getJson('/api/graphs'), getJson('/api/recordings')]);
    this.recordings = recordings;
    $('live-graph').replaceChildren(...graphs.graphs.map((g) => new Option(g, g)));
    $('live-recording').replaceChildren(...recordings.map((r) => new Option(`${r.name} (${r.duration_s.toFixed(1)} s)`, String(r.id))));
    this.bind();
    this.connect();
    $('live').dataset.ready = 'true';
  }

  bind() {
    $('live-start').addEventListener('click', () => this.command(() => sendJson('POST', '/api/live', {
      graph: $('live-graph').value,
      recording: Number($('live-recording').value),
      speed: Number($('live-speed').value),
    })));
    $('live-idle').addEventListener('click', () => this.command(() => sendJson('POST', '/api/live/state', { request: 'idle' })));
    $('live-resume').addEventListener('click', () => this.command(() => sendJson('POST', '/api/live/state', { request: 'initialize' })));
    $('live-stop').addEventListener('click', () => this.command(() => sendJson('DELETE', '/api/live')));
  }

  async command(request) {
    try {
      this.showState(await request());
      $('live-error').textContent = '';
    } catch (e) {
      $('live-error').textContent = e.message;
    }
  }

  connect() {
    this.socket = openSocket('/ws/live');
    this.socket.addEventListener('message', (event) => this.receive(event.data));
    this.socket.addEventListener('close', (event) => {
      $('live-error').textContent = `the live stream closed (${event.code}${event.reason ? `: ${event.reason}` : ''})`;
    });
  }

  receive(data) {
    if (typeof data !== 'string') {
      const { header, payload } = splitFrame(data);
      if (header.type === 'points') this.scene.setPoints(header, data, payload.byteOffset);
      else this.showImage(header, new Blob([payload], { type: 'image/jpeg' }));
      return;
    }
    const frame = JSON.parse(data);
    if (frame.type === 'pose') {
      // A run's first poses may come before its state.
      if (String(frame.run) !== this.runKey) this.beginRun(String(frame.run));
      this.plot.add(frame);
      this.scene.setEstimate({ ...frame, source: frame.dfpc });
      this.scene.extendTrack('estimate', frame);
      this.scene.setTruth(frame.truth ? { ...frame.truth, source: frame.truth.channel } : null);
      if (frame.error) this.errors.add(frame.t, frame.error);
      $('live-pose').textContent = `${frame.dfpc}: ${frame.child_frame} in ${frame.frame} at ${frame.t.toFixed(2)} s: `
        + `(${frame.p.map((v) => v.toFixed(3)).join(', ')}) m, σ (${[0, 7, 14].map((i) => Math.sqrt(frame.covariance[i]).toFixed(3)).join(', ')}) m`;
    } else if (frame.type === 'status') {
      this.showDfpcs([frame]);
      $('live-state').textContent = `CDFF ${frame.cdff_state}${frame.input_ended ? ', the recording has been consumed' : ''}`;
      document.body.dataset.liveState = frame.cdff_state;
    } else if (frame.type === 'event') {
      this.addEvent(frame);
    } else if (frame.type === 'state') {
      this.showState(frame);
    } else if (frame.type === 'error') {
      $('live-error').textContent = frame.error;
    }
  }

  showState(run) {
    this.run = run;
    const active = Boolean(run.active);
    const state = active ? run.state : 'none';
    document.body.dataset.liveState = state;
    $('live-state').textContent = active
      ? `CDFF ${run.state}: ${run.graph} on recording ${run.recording} at ${run.speed}x${run.input_ended ? ', the recording has been consumed' : ''}`
      : `no live run${run.last ? ` (the last one ended ${run.last.state})` : ''}`;
    $('live-start').disabled = active;
    $('live-idle').disabled = !active || state !== 'running';
    $('live-resume').disabled = !active || state === 'running';
    $('live-stop').disabled = !active;
    if (!active) return;
    if (run.dfpcs) this.showDfpcs(run.dfpcs);
    if (run.pose_error) $('live-pose').textContent = `no pose to plot: ${run.pose_error}`;
    const key = String(run.run);
    if (key !== this.runKey) this.beginRun(key);
    if (this.truthFor !== key) {  // the run's first state: its events so far, its truth
      this.truthFor = key;
      $('live-events').replaceChildren();
      for (const e of run.events ?? []) this.addEvent(e);
      this.loadTruth(run.recording).catch((e) => { $('live-error').textContent = e.message; });
      this.loadScene(run).catch((e) => { $('live-error').textContent = e.message; });
    }
  }

  beginRun(key) {
    this.runKey = key;
    this.plot.reset('estimated position (m)');
    this.errors.clear();
    this.scene.setTrack('estimate', null);
    this.scene.setTrack('truth', null);
    this.errors.title = 'error of the estimate against the recording\'s truth, and the requirement thresholds';
  }

  // The 3D view of a run: the recording's mountings, and the graph's model (its mesh_file), or
  // the recording's TriangleMesh channel when the graph names none (the caption says which).
  async loadScene(run) {
    const info = await getJson(`/api/recordings/${run.recording}`);
    const resources = await recordingScene(info);
    this.scene.setMountings(resources.mountings);
    if (run.model_file) {
      const { header, geometry } = meshGeometry(await getBinary('/api/graphs/model', { graph: run.graph }));
      this.scene.setModel(geometry, `${header.source} (the graph's mesh_file)`);
    } else if (resources.mesh) {
      this.scene.setModel(resources.mesh.geometry, `${resources.meshChannel} of the recording (the graph names no mesh_file)`);
    }
  }

  async loadTruth(recordingId) {
    const info = await getJson(`/api/recordings/${recordingId}`);
    const truth = info.channels.filter((c) => c.topic.startsWith('/truth/') && POSE_TYPES.includes(c.type) && c.messages > 0);
    const pick = truth.find((c) => c.topic === '/truth/target_pose') ?? truth[0];
    if (!pick) {
      this.plot.setTruth(null, 'estimated position (m); the recording has no /truth/ pose channel');
      return;
    }
    const poses = await getJson(`/api/recordings/${recordingId}/poses`, { channel: pick.topic, max_points: 4000 });
    this.plot.setTruth(poses, `estimated position (solid) and ${pick.topic} (dashed, ${poses.child_frame} in ${poses.frame}), m`);
    this.scene.setTrack('truth', poses);
  }

  showDfpcs(dfpcs) {
    const body = $('live-dfpcs').tBodies[0];
    for (const d of dfpcs) {
      let row = [...body.rows].find((r) => r.dataset.name === d.name);
      if (!row) {
        row = body.insertRow();
        row.dataset.name = d.name;
        for (let i = 0; i < 7; i += 1) row.insertCell();
        // initDFPC and stopDFPC of this DFPC alone.
        const actions = row.insertCell();
        for (const [label, request] of [['Init', 'init'], ['Stop', 'stop']]) {
          const button = document.createElement('button');
          button.type = 'button';
          button.textContent = label;
          button.dataset.request = request;
          button.addEventListener('click', () => this.command(() => sendJson(
            'POST', `/api/live/dfpcs/${encodeURIComponent(d.name)}`, { request })));
          actions.append(button);
        }
      }
      const step = (d.instances ?? []).reduce((sum, i) => sum + (i.mean_wall_s ?? 0), 0);
      const cells = [d.name, d.error ?? d.state, d.track_state ?? '-', String(d.products ?? '-'),
                     String(d.faults ?? '-'), d.last_fault || '-', step > 0 ? `${(step * 1e3).toFixed(2)} ms` : '-'];
      cells.forEach((text, i) => { row.cells[i].textContent = text; });
      row.dataset.state = d.state ?? '';
    }
  }

  addEvent(frame) {
    const e = frame.event;
    const li = document.createElement('li');
    li.className = e.level;
    li.textContent = `${frame.t === null ? '-' : `${frame.t.toFixed(2)} s`} [${e.level}] ${e.dfpc}${e.instance ? `/${e.instance}` : ''}: ${e.type}${e.message ? ` — ${e.message}` : ''}`;
    const list = $('live-events');
    list.prepend(li);
    while (list.children.length > MAX_EVENTS) list.lastChild.remove();
  }

  showImage(header, blob) {
    const img = $('live-frame');
    const previous = this.imageUrl;
    this.imageUrl = URL.createObjectURL(blob);
    img.src = this.imageUrl;
    if (previous) URL.revokeObjectURL(previous);
    img.dataset.t = header.t.toFixed(6);
    if (header.contour?.segments) {
      this.overlay.show(header.contour, header.source_width, header.source_height,
                        `model at the estimate of ${header.contour.pose_t.toFixed(2)} s`);
    } else {
      this.overlay.clear();
    }
    $('live-frame-caption').textContent = `${header.channel}: frame at ${header.t.toFixed(3)} s `
      + `(${header.source_width}×${header.source_height}, shown at ${header.width}×${header.height})`
      + (header.contour?.error ? ` — no contour: ${header.contour.error}` : '');
  }
}
