// The 3D view (docs/web-ui.md#the-3d-view), three.js: the latest LIDAR scan (thinned by the
// server, Float32 x, y, z), the target's model at the estimated pose (shaded) and at the true
// pose (a green wireframe), all in the scan's frame (the sensor's; REP-103: x forward, z up).
// A pose in another frame is brought into it with the recording's mounting transform
// (parent_T_sensor, e.g. /chaser/tf/lidar = servicer_T_lidar).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { getBinary, getJson } from './api.js';

const BACKGROUND = 0x10151d;

const modelMaterial = () => new THREE.MeshStandardMaterial({
  color: 0x5dade2, metalness: 0.1, roughness: 0.7, transparent: true, opacity: 0.85, side: THREE.DoubleSide,
});
const truthMaterial = () => new THREE.LineBasicMaterial({ color: 0x2ecc71 });

/** A binary body or frame (scene.hpp): 4 bytes of header length, the JSON header, the payload. */
export function splitBinary(buffer) {
  const length = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  return { header, offset: 4 + length };
}

/** A mesh body (GET .../mesh, /api/graphs/model) as a three.js geometry. */
export function meshGeometry(buffer) {
  const { header, offset } = splitBinary(buffer);
  // The payload may start at any byte: copy it to aligned typed arrays.
  const bytes = new Uint8Array(buffer, offset);
  const vertexBytes = header.vertices * 12;
  const positions = new Float32Array(bytes.slice(0, vertexBytes).buffer);
  const indices = new Uint32Array(bytes.slice(vertexBytes, vertexBytes + header.triangles * 12).buffer);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setIndex(new THREE.BufferAttribute(indices, 1));
  geometry.computeVertexNormals();
  geometry.computeBoundingSphere();
  return { header, geometry };
}

/** A pose {p: [x, y, z], q: [w, x, y, z]} as a Matrix4 (parent_T_child). */
export function poseMatrix(p, q) {
  return new THREE.Matrix4().compose(new THREE.Vector3(p[0], p[1], p[2]),
                                     new THREE.Quaternion(q[1], q[2], q[3], q[0]),
                                     new THREE.Vector3(1, 1, 1));
}

export class SceneView {
  /** `canvas`: where it draws; `caption`: what it says about what it shows. */
  constructor(canvas, caption) {
    this.canvas = canvas;
    this.caption = caption;
    // No multisampling: a browser without a GPU renders on the CPU (SwiftShader).
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.setClearColor(BACKGROUND);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.6));
    const light = new THREE.DirectionalLight(0xffffff, 1.2);
    light.position.set(-1, 1, 2);
    this.scene.add(light);
    this.scene.add(new THREE.AxesHelper(1));  // the sensor's frame: x red, y green, z blue
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.05, 5000);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(-3, 0, 1.5);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.requestDraw());
    this.points = new THREE.Points(new THREE.BufferGeometry(),
                                   new THREE.PointsMaterial({ color: 0xffd166, size: 2, sizeAttenuation: false }));
    this.points.frustumCulled = false;
    this.scene.add(this.points);
    this.estimate = null;  // the model at the estimated pose
    this.truth = null;  // its wireframe at the true pose
    this.sensorFrame = '';  // the scan's frame, the view's
    this.mountings = [];  // {parent, child, matrix}: parent_T_child
    this.framed = false;
    this.poses = { estimate: null, truth: null };  // the latest, placed again when the frame changes
    this.tracks = { estimate: null, truth: null };  // trajectories {frame, x, y, z} and their lines
    this.trackLines = { estimate: null, truth: null };
    this.notes = { points: 'no scan', model: 'no model', estimate: '', truth: '' };
    this.pending = false;
    this.warmUp();
    this.resize();
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  // Compiles the model's and the wireframe's shaders now, on a placeholder, rather than when the
  // first model arrives (seconds on a CPU renderer, during which the stream would back up).
  warmUp() {
    const box = new THREE.BoxGeometry(1, 1, 1);
    const placeholders = [new THREE.Mesh(box, modelMaterial()), new THREE.LineSegments(new THREE.EdgesGeometry(box), truthMaterial())];
    for (const p of placeholders) {
      p.position.set(5, 0, 0);
      this.scene.add(p);
    }
    this.renderer.render(this.scene, this.camera);
    for (const p of placeholders) this.scene.remove(p);
    box.dispose();
  }

  resize() {
    const width = this.canvas.clientWidth || 640;
    const height = this.canvas.clientHeight || 360;
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.requestDraw();
  }

  /** The recording's mounting transforms ({frame, child_frame, p, q} each). */
  setMountings(list) {
    this.mountings = list.map((m) => ({ parent: m.frame, child: m.child_frame, matrix: poseMatrix(m.p, m.q) }));
    this.drawTrack('estimate');
    this.drawTrack('truth');
  }

  /**
   * The trajectory of the target's origin, truth or estimate: {frame, x: [], y: [], z: []} in
   * `frame` (a pose channel's columns), drawn as a line in the scan's frame; null removes it.
   */
  setTrack(which, track) {
    this.tracks[which] = track && { frame: track.frame, x: [...track.x], y: [...track.y], z: [...track.z] };
    this.drawTrack(which);
  }

  /** One more estimated position (a live pose {frame, p}). */
  extendTrack(which, pose) {
    const track = this.tracks[which];
    if (!track || track.frame !== pose.frame) {
      this.setTrack(which, { frame: pose.frame, x: [pose.p[0]], y: [pose.p[1]], z: [pose.p[2]] });
      return;
    }
    track.x.push(pose.p[0]);
    track.y.push(pose.p[1]);
    track.z.push(pose.p[2]);
    this.drawTrack(which);
  }

  drawTrack(which) {
    const old = this.trackLines[which];
    if (old) {
      this.scene.remove(old);
      old.geometry.dispose();
      this.trackLines[which] = null;
    }
    const track = this.tracks[which];
    const sensorTParent = track && this.fromFrame(track.frame);
    this.canvas.dataset[`${which}Track`] = String(sensorTParent ? track.x.length : 0);
    if (!sensorTParent) {
      this.requestDraw();
      return;
    }
    const xyz = new Float32Array(3 * track.x.length);
    const v = new THREE.Vector3();
    for (let i = 0; i < track.x.length; i += 1) {
      v.set(track.x[i], track.y[i], track.z[i]).applyMatrix4(sensorTParent);
      xyz.set([v.x, v.y, v.z], 3 * i);
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: which === 'truth' ? 0x2ecc71 : 0x5dade2 }));
    line.frustumCulled = false;
    this.trackLines[which] = line;
    this.scene.add(line);
    this.requestDraw();
  }

  /** The model's mesh (meshGeometry) and where it came from. */
  setModel(geometry, source) {
    for (const o of [this.estimate, this.truth]) if (o) this.scene.remove(o);
    this.estimate = new THREE.Mesh(geometry, modelMaterial());
    this.truth = new THREE.LineSegments(new THREE.EdgesGeometry(geometry, 20), truthMaterial());
    for (const o of [this.estimate, this.truth]) {
      o.visible = false;
      o.matrixAutoUpdate = false;
      this.scene.add(o);
    }
    this.notes.model = `model: ${source} (${geometry.index.count / 3} triangles)`;
    this.canvas.dataset.model = String(geometry.index.count / 3);
    this.place(this.estimate, 'estimate', this.poses.estimate);
    this.place(this.truth, 'truth', this.poses.truth);
  }

  /** A points frame: its header and the Float32 x, y, z (copied, aligned). */
  setPoints(header, buffer, offset) {
    const xyz = new Float32Array(new Uint8Array(buffer, offset, header.count * 12).slice().buffer);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    this.points.geometry.dispose();
    this.points.geometry = geometry;
    const moved = header.frame !== this.sensorFrame;
    this.sensorFrame = header.frame;
    if (moved) {
      this.framed = false;
      this.drawTrack('estimate');
      this.drawTrack('truth');
      this.place(this.estimate, 'estimate', this.poses.estimate);
      this.place(this.truth, 'truth', this.poses.truth);
    }
    this.notes.points = `${header.channel}: ${header.count} of ${header.source_count} points `
      + `at ${header.t.toFixed(2)} s, in ${header.frame || 'its frame'}`;
    this.canvas.dataset.points = String(header.count);
    this.canvas.dataset.t = String(header.t);
    this.requestDraw();
  }

  /** sensor_T_parent, or null when the recording has no transform between them. */
  fromFrame(parent) {
    if (!this.sensorFrame || parent === this.sensorFrame) return new THREE.Matrix4();  // no scan yet: the pose's own frame
    const mount = this.mountings.find((m) => m.parent === parent && m.child === this.sensorFrame);
    return mount ? mount.matrix.clone().invert() : null;
  }

  place(object, which, pose) {
    this.poses[which] = pose;
    if (!object) return;
    if (!pose) {
      object.visible = false;
      this.notes[which] = '';
      this.requestDraw();
      return;
    }
    const sensorTParent = this.fromFrame(pose.frame);
    if (!sensorTParent) {
      object.visible = false;
      this.notes[which] = `${which}: no transform from ${pose.frame} to ${this.sensorFrame} in the recording`;
    } else {
      object.matrix.copy(sensorTParent.multiply(poseMatrix(pose.p, pose.q)));
      object.matrixWorldNeedsUpdate = true;
      object.visible = true;
      this.notes[which] = `${which}: ${pose.child_frame ?? 'target'} in ${pose.frame}${pose.source ? ` (${pose.source})` : ''}`;
      if (!this.framed && this.sensorFrame) this.frame(object);
    }
    this.canvas.dataset[which] = String(object.visible);
    this.requestDraw();
  }

  /** The model at the estimated pose {frame, child_frame, p, q, source}; null hides it. */
  setEstimate(pose) { this.place(this.estimate, 'estimate', pose); }

  /** The model's wireframe at the true pose; null hides it. */
  setTruth(pose) { this.place(this.truth, 'truth', pose); }

  // Looks at the target once, from the sensor's side, a few model radii away (the sensor's
  // axes come into view by zooming out).
  frame(object) {
    const centre = new THREE.Vector3().setFromMatrixPosition(object.matrix);
    const radius = Math.max(object.geometry.boundingSphere?.radius ?? 1, 0.1);
    const toward = centre.lengthSq() > 0 ? centre.clone().normalize() : new THREE.Vector3(1, 0, 0);
    this.camera.position.copy(centre).addScaledVector(toward, -3 * radius).add(new THREE.Vector3(0, 0, 0.8 * radius));
    this.camera.far = Math.max(5000, 4 * centre.length());
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.framed = true;
  }

  requestDraw() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.renderer.render(this.scene, this.camera);
      this.canvas.dataset.draws = String(Number(this.canvas.dataset.draws ?? 0) + 1);
      this.caption.textContent = [this.notes.points, this.notes.model, this.notes.estimate, this.notes.truth]
        .filter(Boolean).join(' · ');
    });
  }
}

/**
 * What the 3D view takes from a recording (`info`: GET /api/recordings/<id>): its mounting
 * transforms (the Transform channels under /chaser/tf/, first pose each) and its first
 * TriangleMesh channel, the simulator's /truth/target_mesh (null when it has none).
 */
export async function recordingScene(info) {
  const tf = info.channels.filter((c) => c.type === 'Transform' && c.topic.startsWith('/chaser/tf/') && c.messages > 0);
  const mountings = await Promise.all(tf.map(async (c) => {
    const p = await getJson(`/api/recordings/${info.id}/poses`, { channel: c.topic, max_points: 2 });
    return { frame: p.frame, child_frame: p.child_frame, p: [p.x[0], p.y[0], p.z[0]], q: [p.qw[0], p.qx[0], p.qy[0], p.qz[0]] };
  }));
  const meshChannel = info.channels.find((c) => c.type === 'TriangleMesh' && c.messages > 0);
  const mesh = meshChannel
    ? meshGeometry(await getBinary(`/api/recordings/${info.id}/mesh`, { channel: meshChannel.topic }))
    : null;
  return { mountings, mesh, meshChannel: meshChannel?.topic };
}
