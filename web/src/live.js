// The Live page (docs/web-ui.md#the-live-run): a DFPC graph run on a served recording through
// the server's /api/live routes (the §7.3 external API: setCDFFState, initDFPC, stopDFPC,
// designateTarget), watched over /ws/live: the camera image being processed, with the regions the
// DFPC designated and matched drawn on it; a box dragged on it designates the target
// (far-range tracking starts from it); the bearing against the truth; the estimated position
// against the truth, each DFPC's state and faults, the events log.
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
const SVG = 'http://www.w3.org/2000/svg';
const mrad = (radians) => (radians * 1e3).toFixed(2);

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
    this.frameSize = null;  // the camera's full resolution {width, height}, once an image came
    this.drag = null;  // the box being dragged: {from, to} in full-resolution edge coordinates
    this.plotTruthFrames = '';  // "frame/child" of the plot's truth
    this.bearingTruth = null;  // {name, poses}: the target's truth in the bearings' frame
    this.bearings = 0;
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
    this.bindOverlay();
  }

  // ---- designation: a box dragged on the image --------------------------------------------------
  // The overlay's coordinates are the camera's full-resolution pixels with the image's left edge
  // at 0 (pixel i spans [i, i + 1]; the server's pixel centres are at integer coordinates, i.e.
  // at i + 0.5 here): the image shown may be decimated, the box sent never is.

  bindOverlay() {
    const overlay = $('live-overlay');
    overlay.addEventListener('pointerdown', (e) => {
      if (e.button !== 0 || !this.frameSize || !this.run?.active) return;
      e.preventDefault();
      overlay.setPointerCapture(e.pointerId);
      const at = this.toImage(e);
      this.drag = { from: at, to: at };
      this.showDrag();
    });
    overlay.addEventListener('pointermove', (e) => {
      if (!this.drag) return;
      this.drag.to = this.toImage(e);
      this.showDrag();
    });
    const end = (e, send) => {
      if (!this.drag) return;
      this.drag.to = this.toImage(e);
      const box = this.dragBox();
      this.drag = null;
      $('live-drag').setAttribute('visibility', 'hidden');
      if (send && box) this.designate(box);
    };
    overlay.addEventListener('pointerup', (e) => end(e, true));
    overlay.addEventListener('pointercancel', (e) => end(e, false));
  }

  /** A pointer's position in full-resolution pixels (edge coordinates), clamped to the image. */
  toImage(e) {
    const r = $('live-overlay').getBoundingClientRect();
    const { width, height } = this.frameSize;
    const clamp = (v, hi) => Math.min(Math.max(v, 0), hi);
    return {
      u: clamp(((e.clientX - r.left) / r.width) * width, width),
      v: clamp(((e.clientY - r.top) / r.height) * height, height),
    };
  }

  /** The pixels the drag covers as {x, y, w, h} (x, y: the first pixel); null for a click. */
  dragBox() {
    const { from, to } = this.drag;
    const x = Math.floor(Math.min(from.u, to.u));
    const y = Math.floor(Math.min(from.v, to.v));
    const w = Math.ceil(Math.max(from.u, to.u)) - x;
    const h = Math.ceil(Math.max(from.v, to.v)) - y;
    return w >= 2 && h >= 2 ? { x, y, w, h } : null;
  }

  showDrag() {
    const box = this.dragBox();
    const rect = $('live-drag');
    if (!box) {
      rect.setAttribute('visibility', 'hidden');
      return;
    }
    setAttributes(rect, { x: box.x, y: box.y, width: box.w, height: box.h, visibility: 'visible' });
  }

  async designate(box) {
    try {
      const answer = await sendJson('POST', '/api/live/designation', box);
      this.showDesignation(answer.designation);
      $('live-error').textContent = '';
    } catch (e) {
      $('live-error').textContent = e.message;
    }
  }

  /** A designation (this page's or another browser's): its box, and what received it. */
  showDesignation(d) {
    const rect = this.shape('designation', 'rect', 'designation');
    setAttributes(rect, { x: d.x, y: d.y, width: d.width, height: d.height });
    const shown = $('live-view').dataset.camera;
    $('live-designation').textContent = `designated ${d.width}×${d.height} px at (${d.x}, ${d.y}) of `
      + `${d.image.channel} (${d.image.width}×${d.image.height}, the image of ${d.image.t.toFixed(2)} s) `
      + `at ${d.t.toFixed(2)} s, to ${d.dfpcs.join(', ')}`
      + (shown && shown !== d.image.channel ? `; the image shown is ${shown}, not that one` : '');
    $('live-designation').dataset.t = String(d.t);
  }

  /** A region product (a designation, a match): its outline, one per output. */
  showRegion(frame) {
    const kind = ['match', 'designated'].includes(frame.output) ? frame.output : 'other';
    const polygon = this.shape(`region-${frame.output}`, 'polygon', `region ${kind}`);
    polygon.setAttribute('points', frame.corners.map(([x, y]) => `${x + 0.5},${y + 0.5}`).join(' '));
    const title = polygon.querySelector('title') ?? polygon.appendChild(document.createElementNS(SVG, 'title'));
    title.textContent = `${frame.output} (${frame.source}${frame.score === null ? '' : `, score ${frame.score.toFixed(2)}`}) at ${frame.t.toFixed(2)} s`;
    $('live-overlay').dataset[`${kind}T`] = String(frame.t);
  }

  /** The overlay's element `id` (created once). */
  shape(id, tag, className) {
    let element = document.getElementById(`live-shape-${id}`);
    if (!element) {
      element = document.createElementNS(SVG, tag);
      element.id = `live-shape-${id}`;
      element.setAttribute('class', className);
      $('live-overlay').insertBefore(element, $('live-drag'));
    }
    return element;
  }

  clearOverlay() {
    for (const e of [...$('live-overlay').querySelectorAll('[id^="live-shape-"]')]) e.remove();
    for (const key of Object.keys($('live-overlay').dataset)) delete $('live-overlay').dataset[key];
    $('live-designation').textContent = '';
    $('live-bearing').textContent = '';
    delete $('live-bearing').dataset.count;
    this.bearings = 0;
    this.bearingTruth = null;
  }

  /** A bearing product: its angles, and its angle to the truth when the recording has one. */
  showBearing(frame) {
    this.loadBearingTruth(frame);
    this.bearings += 1;
    let text = `${frame.dfpc}: bearing at ${frame.t.toFixed(2)} s, azimuth ${mrad(frame.azimuth)} mrad, `
      + `elevation ${mrad(frame.elevation)} mrad (σ ${mrad(frame.sigma)} mrad) in ${frame.frame}`;
    if (frame.range !== null) text += `, range ${frame.range.toFixed(1)} m`;
    if (frame.designation) text += `, designated by ${frame.designation}`;
    const error = this.bearingError(frame);
    if (error !== null) text += `; ${mrad(error)} mrad from ${this.bearingTruth.name}`;
    const p = $('live-bearing');
    p.textContent = text;
    p.dataset.count = String(this.bearings);
    p.dataset.designation = frame.designation ?? '';
  }

  /** The angle (rad) between a bearing and the truth's direction to the target at its time. */
  bearingError(frame) {
    const truth = this.bearingTruth?.poses;
    if (!truth || truth.frame !== frame.frame || truth.t.length === 0) return null;
    let lo = 0;
    let hi = truth.t.length - 1;
    while (lo < hi) {  // the first sample at or after the bearing
      const mid = (lo + hi) >> 1;
      if (truth.t[mid] < frame.t) lo = mid + 1; else hi = mid;
    }
    const i = lo > 0 && Math.abs(truth.t[lo - 1] - frame.t) < Math.abs(truth.t[lo] - frame.t) ? lo - 1 : lo;
    if (Math.abs(truth.t[i] - frame.t) > 0.2) return null;
    const p = [truth.x[i], truth.y[i], truth.z[i]];
    const d = frame.direction;
    const dot = p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
    const cross = Math.hypot(p[1] * d[2] - p[2] * d[1], p[2] * d[0] - p[0] * d[2], p[0] * d[1] - p[1] * d[0]);
    return Math.atan2(cross, dot);
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
      this.followPoseFrames(frame);
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
    } else if (frame.type === 'bearing') {
      if (String(frame.run) === this.runKey) this.showBearing(frame);
    } else if (frame.type === 'region') {
      if (String(frame.run) === this.runKey) this.showRegion(frame);
    } else if (frame.type === 'designation') {
      if (String(frame.run) === this.runKey) this.showDesignation(frame);
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
    this.clearOverlay();
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

  /**
   * A /truth/ pose channel of a recording, as columns with its name: /truth/target_pose or the
   * first, or, given `frame` and `child`, the first whose poses are frame_T_child; null if none.
   */
  async findTruth(recordingId, frame, child) {
    const info = await getJson(`/api/recordings/${recordingId}`);
    const channels = info.channels.filter((c) => c.topic.startsWith('/truth/') && POSE_TYPES.includes(c.type) && c.messages > 0);
    channels.sort((a, b) => Number(b.topic === '/truth/target_pose') - Number(a.topic === '/truth/target_pose'));
    for (const c of channels) {
      if (frame) {
        const head = await getJson(`/api/recordings/${recordingId}/poses`, { channel: c.topic, max_points: 2 });
        if (head.frame !== frame || head.child_frame !== child) continue;
      }
      const poses = await getJson(`/api/recordings/${recordingId}/poses`, { channel: c.topic, max_points: 4000 });
      return { name: c.topic, poses };
    }
    return null;
  }

  /**
   * The plot's truth: first the recording's /truth/target_pose (or first /truth/ pose channel);
   * once the DFPC's first pose tells its frames, the truth channel in those frames, so that the
   * plot compares like with like (none: no truth, and the title says why).
   */
  async loadTruth(recordingId, pose) {
    this.truthRequest = (this.truthRequest ?? 0) + 1;
    const request = this.truthRequest;
    const found = await this.findTruth(recordingId, pose?.frame, pose?.child_frame);
    if (request !== this.truthRequest) return;  // a newer request replaced it
    if (!found) {
      this.plotTruthFrames = pose ? `${pose.frame}/${pose.child_frame}` : '';
      this.plot.setTruth(null, pose
        ? `estimated position of ${pose.child_frame} in ${pose.frame} (m); the recording has no /truth/ pose channel in these frames`
        : 'estimated position (m); the recording has no /truth/ pose channel');
      return;
    }
    this.plotTruthFrames = `${found.poses.frame}/${found.poses.child_frame}`;
    this.plot.setTruth(found.poses, `estimated position (solid) and ${found.name} (dashed, ${found.poses.child_frame} in ${found.poses.frame}), m`);
    this.scene.setTrack('truth', found.poses);
  }

  /** The run's first pose: the plot's truth follows its frames. */
  followPoseFrames(frame) {
    if (this.poseFramesFor === this.runKey || String(this.run?.run) !== this.runKey) return;
    this.poseFramesFor = this.runKey;
    if (this.plotTruthFrames === `${frame.frame}/${frame.child_frame}`) return;
    this.loadTruth(this.run.recording, frame).catch((e) => { $('live-error').textContent = e.message; });
  }

  /** The run's first bearing: the truth channel of the target in the bearing's frame. */
  loadBearingTruth(frame) {
    if (this.bearingTruthFor === this.runKey || String(this.run?.run) !== this.runKey) return;
    this.bearingTruthFor = this.runKey;
    const key = this.runKey;
    this.findTruth(this.run.recording, frame.frame, 'target')
      .then((found) => { if (key === this.runKey) this.bearingTruth = found; })
      .catch((e) => { $('live-error').textContent = e.message; });
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
      row.dataset.track = d.track_state ?? '';
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
    // The overlay draws in the camera's full-resolution pixels, whatever the image's decimation.
    if (this.frameSize?.width !== header.source_width || this.frameSize?.height !== header.source_height) {
      this.frameSize = { width: header.source_width, height: header.source_height };
      setAttributes($('live-overlay'), { viewBox: `0 0 ${header.source_width} ${header.source_height}`, preserveAspectRatio: 'none' });
    }
    $('live-view').dataset.camera = header.channel;
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

function setAttributes(element, attributes) {
  for (const [key, value] of Object.entries(attributes)) element.setAttribute(key, String(value));
}
